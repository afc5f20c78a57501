"""SYSID_THISMAV and MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN over pymavlink (issue 8 item 4): as
ArduPilot, a new SYSID_THISMAV is saved at once and applied by a reboot; the reboot is refused
while armed, answers its ACK first (from the old sysid), keeps the parameters and resets state."""
from __future__ import annotations

import pytest

from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, wait_armable

pytestmark = pytest.mark.timeout(120)


def _set(m, name, value):
    m.mav.param_set_send(m.target_system, 1, name.encode(), value, mav.MAV_PARAM_TYPE_INT32)
    return recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == name)


def test_sysid_applies_after_reboot(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=5)
    m = connect(sitl.udp[0])
    assert m.target_system == 1
    wait_armable(m)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert _set(m, "RTL_ALT", 2300).param_value == 2300
    pv = _set(m, "SYSID_THISMAV", 7)
    assert pv.param_value == 7 and pv.get_srcSystem() == 1
    # not applied before a reboot: still sysid 1, still answering commands to 1
    assert recv(m, "HEARTBEAT", 5).get_srcSystem() == 1
    assert command(m, 203) == mav.MAV_RESULT_UNSUPPORTED
    # refused while armed
    assert command(m, 400, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_FAILED
    assert command(m, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0) == mav.MAV_RESULT_FAILED  # armed: checked first
    assert command(m, 400, 0) == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0) == mav.MAV_RESULT_UNSUPPORTED  # 1 or 3 reboot
    # reboot: the ACK comes first, from sysid 1; then heartbeats from 7
    m.mav.command_long_send(1, 1, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0, 1, 0, 0, 0, 0, 0, 0)
    ack = recv(m, "COMMAND_ACK", 5, cond=lambda a: a.command == mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN)
    assert ack.result == mav.MAV_RESULT_ACCEPTED and ack.get_srcSystem() == 1
    hb = recv(m, "HEARTBEAT", 10, cond=lambda h: h.get_srcSystem() == 7)
    assert hb.custom_mode == 0 and not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED   # STABILIZE: reset
    # commands to 7 answered by 7; a command to 1 is no longer ours
    m.target_system = 7
    m.mav.command_long_send(1, 1, 203, 0, 0, 0, 0, 0, 0, 0, 0)        # to the old sysid
    m.mav.command_long_send(7, 1, 204, 0, 0, 0, 0, 0, 0, 0, 0)        # to the new one, after it
    acks = []
    while not any(a.command == 204 for a in acks):
        acks.append(recv(m, "COMMAND_ACK", 5))
    assert [a.command for a in acks] == [204] and acks[0].get_srcSystem() == 7
    # parameters kept (re-read from the saved file), and SYSID_THISMAV reads 7
    m.mav.param_request_read_send(7, 1, b"RTL_ALT", -1)
    assert recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 2300
    m.mav.param_request_read_send(7, 1, b"SYSID_THISMAV", -1)
    pv = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "SYSID_THISMAV")
    assert pv.param_value == 7 and pv.get_srcSystem() == 7
    # the rebooted vehicle works: armable again, arms and disarms as 7
    wait_armable(m)
    assert command(m, 400, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(m, 400, 0) == mav.MAV_RESULT_ACCEPTED
    # and it comes back as 7 after a restart of the process (the saved file)
    m.close()
    assert sitl.stop() == 0
    sitl2 = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=5)
    m2 = connect(sitl2.udp[0])
    assert m2.target_system == 7
    m2.close()


def test_reboot_in_process_keeps_missions_and_touches_only_its_vehicle():
    from test_command_nonfinite import Gcs
    from vehicle.autopilot import modes
    from vehicle.world import World, WorldConfig
    w = World(WorldConfig(drones=1, rovers=1, state_dir=None, tcp_base=None, udp_base=None))
    w.run_for(2.0)
    drone, rover = w.vehicles
    assert rover.ap.set_mode(modes.ROVER_GUIDED) and drone.ap.set_mode(modes.GUIDED)
    store, gcs = rover.ap.missions, Gcs(rover.link)
    assert rover.ap.params.set("SYSID_THISMAV", 9) is None and rover.ap.params.set("CRUISE_SPEED", 3) is None
    assert rover.sysid == 2
    assert gcs.command(mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, [1, 0, 0, 0, 0, 0, 0]) == mav.MAV_RESULT_ACCEPTED
    assert rover.sysid == 9 and rover.link.mav.srcSystem == 9 and rover.ap.mode == modes.ROVER_HOLD
    assert rover.ap.missions is store and rover.ap.home is None and rover.ap.params["CRUISE_SPEED"] == 3
    assert w.fleets[1][1].params_of(0)["CRUISE_SPEED"] == 3          # the fleet has the re-read values
    assert drone.sysid == 1 and drone.ap.mode == modes.GUIDED        # the other vehicle is untouched
    w.run_for(1.0)
    assert rover.ap.home is not None and rover.ap.arm() == mav.MAV_RESULT_ACCEPTED
