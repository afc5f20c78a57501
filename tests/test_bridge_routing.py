"""Bridge routing over loopback UDP: fake vehicles (pymavlink) <-> bridge <-> fake tower.

Heartbeats, commands and acks, parameters pass through with sysid/compid preserved;
messages go to the vehicle named by target_system; garbage on every port is counted
and dropped while routing continues; the CLI process starts, routes and stops.
"""
from __future__ import annotations

import os

import pytest

from common.mavlink.dialect import towerlink as tl
from bridge_fakes import Endpoint, FakeVehicle, bridge_with_fakes, sync
from support import free_ports, wait_until


@pytest.fixture
def world():
    with bridge_with_fakes() as w:
        yield w["bridge"], w["tower"], w["drone"], w["rover"]


def test_heartbeat_command_ack_param_pass_through(world):
    bridge, tower, drone, rover = world
    drone.heartbeat()
    rover.heartbeat()
    hb = tower.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
    assert hb.get_srcComponent() == 1 and hb.type == tl.MAV_TYPE_QUADROTOR
    hb = tower.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 2)
    assert hb.type == tl.MAV_TYPE_GROUND_ROVER
    # tower heartbeat (broadcast) reaches both vehicles with the tower's ids
    tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    for v in (drone, rover):
        m = v.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 255)
        assert m.get_srcComponent() == 190
    # arm + mode on the drone only
    tower.mav.command_long_send(1, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    ack = tower.wait("COMMAND_ACK", lambda m: m.command == tl.MAV_CMD_COMPONENT_ARM_DISARM)
    assert ack.get_srcSystem() == 1 and ack.result == tl.MAV_RESULT_ACCEPTED
    tower.mav.command_long_send(1, 1, tl.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
    tower.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and m.custom_mode == 4 and
               m.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED)
    assert drone.armed and drone.mode == 4
    sync(tower, rover)                  # whatever the bridge sent the rover so far has arrived
    assert not rover.armed and not rover.of_type("COMMAND_LONG", lambda m: m.get_srcSystem() == 255)
    # parameters, by target
    tower.mav.param_request_read_send(2, 1, b"SYSID_THISMAV", -1)
    pv = tower.wait("PARAM_VALUE", lambda m: m.get_srcSystem() == 2)
    assert pv.param_value == 2.0 and pv.param_count == 2
    cmd = drone.of_type("COMMAND_LONG", lambda m: m.get_srcSystem() == 255)[0]
    assert cmd.get_srcComponent() == 190


def test_raw_bytes_forwarded_unchanged(world):
    bridge, tower, drone, rover = world
    msg = tl.MAVLink_sys_status_message(1, 1, 1, 500, 12000, -1, 90, 0, 0, 0, 0, 0, 0)
    raw = bytes(msg.pack(drone.mav))
    drone.send_bytes(raw)
    got = tower.wait("SYS_STATUS")
    assert bytes(got.get_msgbuf()) == raw


def test_a_system_behind_a_vehicle_link_is_routed_as_that_links_traffic(world):
    """A camera (sysid 7) behind the drone's link: its packets reach the tower as sent, and the
    tower's packets for it go down the link it was heard on (learned), not to the rover."""
    bridge, tower, drone, rover = world
    camera = tl.MAVLink(None, 7, tl.MAV_COMP_ID_CAMERA)
    raw = bytes(tl.MAVLink_heartbeat_message(tl.MAV_TYPE_CAMERA, tl.MAV_AUTOPILOT_INVALID, 0, 0, 4, 3)
                .pack(camera))
    drone.send_bytes(raw)
    got = tower.wait("HEARTBEAT", lambda m: m.get_srcSystem() == 7)
    assert bytes(got.get_msgbuf()) == raw
    tower.mav.command_long_send(7, tl.MAV_COMP_ID_CAMERA, tl.MAV_CMD_REQUEST_MESSAGE, 0, 0, 0, 0, 0, 0, 0, 0)
    drone.wait("COMMAND_LONG", lambda m: m.target_system == 7)
    sync(tower, rover)
    assert not rover.of_type("COMMAND_LONG", lambda m: m.target_system == 7)


def test_unknown_target_is_unroutable(world):
    bridge, tower, drone, rover = world
    before = bridge.tower.stats.unroutable
    tower.mav.command_long_send(77, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    wait_until(lambda: bridge.tower.stats.unroutable > before, 5, "unroutable counted")
    assert not drone.of_type("COMMAND_LONG", lambda m: m.target_system == 77)


def _garbage_samples(mav) -> list[bytes]:
    good = bytes(tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav))
    bad_crc = bytearray(good); bad_crc[-1] ^= 0xFF
    unknown = bytearray(good); unknown[7] = 0x37; unknown[8] = 0x9A  # msgid nobody has
    return [os.urandom(200), b"\xfd" * 40, bytes(bad_crc), good[:7], good[:-3], bytes(unknown),
            b"\xfe\x09" + os.urandom(3), b"\x00" * 300]


def test_garbage_on_every_port_counted_and_dropped(world):
    bridge, tower, drone, rover = world
    whole: list[bytes] = []
    for ep, link in ((tower, bridge.tower), (drone, bridge.vehicles[1].link),
                     (rover, bridge.vehicles[2].link)):
        before = link.malformed
        samples = _garbage_samples(ep.mav)
        whole += [samples[i] for i in (0, 1, 2, 5, 7)]     # not the prefixes of a good packet
        for s in samples:
            ep.send_bytes(s)
        wait_until(lambda: link.malformed >= before + len(samples), 5, f"garbage counted on {link.name}")
    # routing continues: a command round trip still works
    tower.mav.command_long_send(2, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    tower.wait("COMMAND_ACK", lambda m: m.get_srcSystem() == 2)
    drone.heartbeat()
    n = len(tower.of_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1))
    drone.heartbeat()
    wait_until(lambda: len(tower.of_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1)) > n, 5, "hb")
    # nothing malformed leaked to the other side: no side's parser met bad data, and
    # no garbage sample's bytes were forwarded (only valid packets, from the bridge's framer)
    for ep in (tower, drone, rover):
        assert ep.bad == [], (ep.name, ep.bad[:3])
    for ep in (tower, drone, rover):
        assert not any(g in r for r in ep.raw for g in whole), ep.name
    # and the counters reach the tower in TOWERLINK_BRIDGE_STATUS
    st = tower.wait("TOWERLINK_BRIDGE_STATUS", lambda m: m.link == "drone" and m.malformed >= 8)
    assert st.rx_packets > 0


def _v1(msg, sysid: int, compid: int, seq: int = 7) -> bytes:
    """`msg` packed as MAVLink 1 (0xFE) from sysid/compid."""
    mav = tl.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq
    return bytes(msg.pack(mav, force_mavlink1=True))


def _v1_bad(good: bytes) -> list[bytes]:
    """Damaged copies of a good MAVLink 1 packet, each failing the CRC check only."""
    assert good[0] == 0xFE and good[1] == len(good) - 8
    crc_lo = bytearray(good); crc_lo[-2] ^= 0x5A                   # CRC byte wrong
    payload = bytearray(good); payload[6 + 4] ^= 0x01              # one payload bit flipped
    seq = bytearray(good); seq[2] ^= 0xFF                          # header byte under the CRC
    return [bytes(crc_lo), bytes(payload), bytes(seq)]


def _bridge_status(tower, link: str, after: float | None = None):
    return tower.wait("TOWERLINK_BRIDGE_STATUS", lambda m: m.link == link and
                      (after is None or m._recv_time > after), what=f"bridge status of {link}")


def test_mavlink1_bad_crc_counted_and_dropped_by_the_bridge(world):
    """MAVLink 1 frames with a bad CRC are dropped by the bridge's own framer (counted on
    the link they came in on), both ways; good MAVLink 1 frames around them still pass."""
    import time
    bridge, tower, drone, rover = world
    # tower -> drone: COMMAND_LONG for sysid 1, as MAVLink 1
    def servo(k):
        return tl.MAVLink_command_long_message(1, 1, tl.MAV_CMD_DO_SET_SERVO, 0, k, 1500, 0, 0, 0, 0, 0)
    bad_up = _v1_bad(_v1(servo(9), 255, 190))
    # drone -> tower: SYS_STATUS from sysid 1, as MAVLink 1
    def sys_status(k):
        return tl.MAVLink_sys_status_message(1, 1, 1, 500, 12000, -1, 90, k, 0, 0, 0, 0, 0)
    bad_down = _v1_bad(_v1(sys_status(9), 1, 1))
    t0 = time.monotonic()
    before = {name: _bridge_status(tower, name, t0).malformed for name in ("tower", "drone")}
    for b in bad_up:
        tower.send_bytes(b)
    tower.send_bytes(bad_up[0] + _v1(servo(1), 255, 190))          # bad then good, one datagram
    for b in bad_down:
        drone.send_bytes(b)
    drone.send_bytes(bad_down[1] + _v1(sys_status(1), 1, 1))
    # the good frames arrive (so everything sent before them has been handled) ...
    tower.send_bytes(_v1(servo(2), 255, 190))
    drone.send_bytes(_v1(sys_status(2), 1, 1))
    drone.wait("COMMAND_LONG", lambda m: m.command == tl.MAV_CMD_DO_SET_SERVO and m.param1 == 2)
    tower.wait("SYS_STATUS", lambda m: m.drop_rate_comm == 2)
    # ... the bad ones were counted by the bridge, on the link each came in on ...
    t1 = time.monotonic()
    st = {name: _bridge_status(tower, name, t1).malformed for name in ("tower", "drone")}
    assert st["tower"] - before["tower"] == 4 and st["drone"] - before["drone"] == 4, (before, st)
    # ... and dropped by it: only the good frames came through, and as MAVLink 1
    servos = drone.of_type("COMMAND_LONG", lambda m: m.command == tl.MAV_CMD_DO_SET_SERVO)
    assert sorted(m.param1 for m in servos) == [1, 2]
    assert sorted(m.drop_rate_comm for m in tower.of_type("SYS_STATUS")) == [1, 2]
    assert all(m.get_msgbuf()[0] == 0xFE for m in servos)
    for ep, bad in ((drone, bad_up), (tower, bad_down), (rover, bad_up + bad_down)):
        assert not any(b in r for r in ep.raw for b in bad), f"a bad frame reached {ep.name}"
        assert ep.bad == [], (ep.name, ep.bad[:3])


def test_cli_process_routes_and_stops(processes):
    tport, dport, rport = free_ports(3)
    drone = FakeVehicle(1, dport, name="drone")
    proc = processes.start(["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{tport}",
                            "--drone", f"udpout:127.0.0.1:{dport}", "--rover", "none", "--no-follow"])
    tower = Endpoint(255, 190, tport, listen=False, name="tower")
    try:
        wait_until(lambda: drone.peer, 10, "bridge heartbeat at the drone")
        def hb():
            drone.heartbeat()
            tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            return tower.of_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
        wait_until(hb, 10, "drone heartbeat at the tower through the bridge process", interval=0.1)
        # static frames are streamed
        ts = tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "tower", timeout=5)
        assert ts.frame_id == "world" and ts.flags & 1
    finally:
        tower.close(); drone.close()
        processes.stop(proc)
    out = proc.stdout.read()
    assert proc.returncode == 0, out
    assert "tower: rx" in out
