"""Boot HEARTBEATs: `towerlink sitl` is seen on its udpout pushes while the world loads."""
from __future__ import annotations

import socket

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.boot_beacon import BootBeacon, boot_targets
from vehicle.world_config import WorldConfig


def _cfg(**kw) -> WorldConfig:
    return WorldConfig(drones=1, rovers=1, tcp_base=None, udp_base=None, state_dir=None, **kw)


def test_targets_are_the_udpout_pushes_of_every_vehicle():
    cfg = _cfg(outs=["udpout:127.0.0.1:14550"], endpoints={1: ["udpin:127.0.0.1:20001"]})
    got = boot_targets(cfg, cfg.network_plan())
    assert got == [(1, mav.MAV_TYPE_QUADROTOR, ("127.0.0.1", 14550)),
                   (2, mav.MAV_TYPE_GROUND_ROVER, ("127.0.0.1", 14550))]


def test_a_saved_sysid_wins_and_an_unreadable_one_gets_no_heartbeat(tmp_path):
    (tmp_path / "drone0.parm").write_text("SYSID_THISMAV 7\n")
    (tmp_path / "rover0.parm").write_bytes(b"\x00\xff\xfe garbage")
    cfg = _cfg(outs=["udpout:127.0.0.1:14550"])
    cfg.state_dir = str(tmp_path)
    assert [(s, t) for s, t, _ in boot_targets(cfg, cfg.network_plan())] == [(7, mav.MAV_TYPE_QUADROTOR)]


def test_beacon_sends_boot_heartbeats_until_stopped():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(2.0)
        beacon = BootBeacon([(3, mav.MAV_TYPE_QUADROTOR, rx.getsockname())]).start()
        try:
            msgs = mav.MAVLink(None).parse_buffer(rx.recv(65535))
        finally:
            beacon.stop()
        assert len(msgs) == 1
        hb = msgs[0]
        assert hb.get_type() == "HEARTBEAT" and hb.get_srcSystem() == 3 and hb.get_srcComponent() == 1
        assert hb.system_status == mav.MAV_STATE_BOOT and hb.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert hb.type == mav.MAV_TYPE_QUADROTOR
        sent = beacon.sent
        rx.settimeout(1.3)
        try:
            rx.recv(65535)
            late = True
        except socket.timeout:
            late = False
        assert not late and beacon.sent == sent


def test_no_targets_no_thread():
    beacon = BootBeacon([]).start()
    beacon.stop()
    assert beacon.sent == 0
