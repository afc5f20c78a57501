"""pymavlink exactly as an ArduPilot SITL script: GUIDED, arm, takeoff, goal, land; rover goal.

The world is the towerlink_sitl fixture's (towerlink's pytest plugin), at speedup 10 as a
script's wall-clock deadlines expect."""
from __future__ import annotations

import pytest

from test_sitl_support import command, connect, goto_local, local_pos, mav, recv, set_mode, \
    wait_armable, wait_position


@pytest.mark.timeout(120)
@pytest.mark.towerlink(drones=1, rovers=1, speedup=10)
def test_copter_takeoff_goto_land_udp(towerlink_sitl):
    m = connect(towerlink_sitl.udp_port(0))
    assert m.target_system == 1
    assert m.messages["HEARTBEAT"].type == mav.MAV_TYPE_QUADROTOR
    assert m.messages["HEARTBEAT"].autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert "GUIDED" in m.mode_mapping() and m.mode_mapping()["GUIDED"] == 4
    wait_armable(m)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    m.arducopter_arm()
    m.motors_armed_wait()
    assert m.motors_armed()
    assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 5.0) == mav.MAV_RESULT_ACCEPTED
    recv(m, "GLOBAL_POSITION_INT", 30, cond=lambda g: g.relative_alt > 4700)
    recv(m, "EXTENDED_SYS_STATE", 10, cond=lambda e: e.landed_state == mav.MAV_LANDED_STATE_IN_AIR)
    goto_local(m, 10.0, 5.0, -6.0)
    wait_position(m, (10.0, 5.0, -6.0), 0.5, 40)
    # stays there
    p = local_pos(m)
    assert abs(p.x - 10) < 0.6 and abs(p.y - 5) < 0.6
    assert set_mode(m, "LAND") == mav.MAV_RESULT_ACCEPTED
    recv(m, "HEARTBEAT", 60, cond=lambda h: not (h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED))
    p = local_pos(m)
    assert p.z > -0.3 and abs(p.x - 10) < 1.0 and abs(p.y - 5) < 1.0
    e = recv(m, "EXTENDED_SYS_STATE", 5)
    assert e.landed_state == mav.MAV_LANDED_STATE_ON_GROUND


@pytest.mark.timeout(120)
@pytest.mark.towerlink(drones=1, rovers=1, speedup=10)
def test_rover_guided_goal_tcp(towerlink_sitl):
    m = connect(towerlink_sitl.tcp_port(1), tcp=True)
    assert m.target_system == 2
    assert m.messages["HEARTBEAT"].type == mav.MAV_TYPE_GROUND_ROVER
    assert m.mode_mapping()["GUIDED"] == 15
    wait_armable(m)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    m.arducopter_arm()
    m.motors_armed_wait()
    goto_local(m, 15.0, 10.0, 0.0)
    wait_position(m, (15.0, 10.0, 0.0), 0.5, 60, idx=(0, 1))
    assert set_mode(m, "HOLD") == mav.MAV_RESULT_ACCEPTED
