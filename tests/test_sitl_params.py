"""Parameters persist across restarts (state dir) and --params FILE gives defaults; SIGTERM stops cleanly;
each vehicle has its own parameters (a PARAM_SET or DO_CHANGE_SPEED reaches only its vehicle)."""
from __future__ import annotations

import math
import time

import pytest

from test_sitl_support import Sitl, command, connect, goto_local, local_pos, mav, recv, set_mode, wait_armable


def _read(m, name):
    m.mav.param_request_read_send(m.target_system, 1, name.encode(), -1)
    return recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == name).param_value


@pytest.mark.timeout(90)
def test_param_saved_and_loaded_on_restart(processes, tmp_path):
    parm = tmp_path / "defaults.parm"
    parm.write_text("# defaults\nDISARM_DELAY 7\nSYSID_THISMAV 42\n")
    state = tmp_path / "state"
    sitl = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=2, state_dir=state, extra=["--params", str(parm)])
    m = connect(sitl.udp[0])
    assert _read(m, "DISARM_DELAY") == 7 and _read(m, "SYSID_THISMAV") == 1   # sysid is per vehicle
    m.mav.param_set_send(1, 1, b"RTL_ALT", 2500, mav.MAV_PARAM_TYPE_INT32)
    assert recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 2500
    r = connect(sitl.udp[1])
    r.mav.param_set_send(2, 1, b"FS_ACTION", 1, mav.MAV_PARAM_TYPE_INT32)
    assert recv(r, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "FS_ACTION").param_value == 1
    m.close(); r.close()
    assert sitl.stop() == 0                          # SIGTERM: clean exit
    assert "stats:" in sitl.output()
    assert "RTL_ALT 2500" in (state / "drone0.parm").read_text()
    sitl2 = Sitl(processes, tmp_path, drones=1, rovers=1, speedup=2, state_dir=state, extra=["--params", str(parm)])
    m = connect(sitl2.udp[0])
    assert _read(m, "RTL_ALT") == 2500 and _read(m, "DISARM_DELAY") == 7
    r = connect(sitl2.udp[1])
    assert _read(r, "FS_ACTION") == 1


def _fly_both(ms, dx, timeout):
    """Send each drone dx m north of where it is; max horizontal speed per drone (m/s)
    from LOCAL_POSITION_NED until both have arrived."""
    starts = [local_pos(m) for m in ms]
    for m, s in zip(ms, starts):
        goto_local(m, s.x + dx, s.y, s.z)
    top, done = [0.0] * len(ms), [False] * len(ms)
    deadline = time.monotonic() + timeout
    while not all(done):
        assert time.monotonic() < deadline, (top, done)
        for k, (m, s) in enumerate(zip(ms, starts)):
            p = m.recv_match(type="LOCAL_POSITION_NED", blocking=False)
            if p is None:
                continue
            top[k] = max(top[k], math.hypot(p.vx, p.vy))
            done[k] = done[k] or abs(p.x - (s.x + dx)) < 0.5 and math.hypot(p.vx, p.vy) < 0.3
        time.sleep(0.002)  # poll
    return top


@pytest.mark.timeout(120)
def test_param_set_reaches_only_its_vehicle(processes, tmp_path):
    """Each vehicle has its own parameters: PARAM_SET WPNAV_SPEED on sysid 1 leaves sysid 2's
    value and flight alone; only drone 1 flies its 20 m leg at the lower speed."""
    sitl = Sitl(processes, tmp_path, drones=2, rovers=0, speedup=5)
    ms = [connect(port) for port in sitl.udp]
    assert [m.target_system for m in ms] == [1, 2]
    ms[0].mav.param_set_send(1, 1, b"WPNAV_SPEED", 200, mav.MAV_PARAM_TYPE_REAL32)
    assert recv(ms[0], "PARAM_VALUE", 5, cond=lambda p: p.param_id == "WPNAV_SPEED").param_value == 200
    assert _read(ms[1], "WPNAV_SPEED") == 500 and _read(ms[0], "WPNAV_SPEED") == 200
    for m in ms:
        wait_armable(m)
        assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
        assert command(m, 400, 1) == mav.MAV_RESULT_ACCEPTED
        assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 4) == mav.MAV_RESULT_ACCEPTED
    for m in ms:
        recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: p.z < -3.8 and abs(p.vz) < 0.2)
    top = _fly_both(ms, 20.0, 40)
    assert top[0] <= 2.5, top                        # drone 1: its own WPNAV_SPEED 2 m/s (+ tracking noise)
    assert top[1] >= 4.5, top                         # drone 2: still the default 5 m/s


def test_param_changes_reach_only_their_vehicle_in_world():
    """In-process World: PARAM_SET (the link's params_changed) and DO_CHANGE_SPEED of one
    vehicle change only that vehicle's fleet gains, for drones and rovers."""
    from vehicle.world import World, WorldConfig
    w = World(WorldConfig(drones=2, rovers=2, state_dir=None, tcp_base=None, udp_base=None))
    (_, drones), (_, rovers) = w.fleets
    d0, d1, r0, r1 = w.vehicles
    d1.link.params.params_changed({"WPNAV_SPEED": 250.0})
    assert [drones.gains_of(i).v_xy for i in range(2)] == [5.0, 2.5]
    assert d0.ap.command(mav.MAV_CMD_DO_CHANGE_SPEED, [0, 3.0, -1, 0, 0, 0, 0]) == mav.MAV_RESULT_ACCEPTED
    assert [drones.gains_of(i).v_xy for i in range(2)] == [3.0, 2.5]
    assert d0.ap.command(mav.MAV_CMD_DO_CHANGE_SPEED, [0, -1, -1, 0, 0, 0, 0]) == mav.MAV_RESULT_ACCEPTED   # back to its param
    assert [drones.gains_of(i).v_xy for i in range(2)] == [5.0, 2.5]
    assert r1.ap.command(mav.MAV_CMD_DO_CHANGE_SPEED, [1, 2.0, -1, 0, 0, 0, 0]) == mav.MAV_RESULT_ACCEPTED
    assert [rovers.gains_of(i).cruise for i in range(2)] == [8.0, 2.0]
    r0.link.params.params_changed({"CRUISE_SPEED": 4.0})
    assert rovers.params_of(0)["CRUISE_SPEED"] == 4.0 and rovers.params_of(1)["CRUISE_SPEED"] == 8.0
