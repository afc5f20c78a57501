"""The fence and rally points with the real fleet and autopilot in-process: a GUIDED goal
outside the fence is ignored (ArduCopter's check_destination_within_fence), a breach says
AC_Fence's words and triggers FENCE_ACTION, pre-arm refuses a bad fence, RTL lands at the
nearest rally point."""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from auto_world import Flight, airborne, goto
from vehicle.autopilot import modes
from vehicle.autopilot.fence_geometry import POLY_IN

C = mav
VEL_ONLY = 0b110111000111


def test_guided_goal_outside_the_circle_fence_is_ignored_and_the_copter_stays_inside():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 2, "FENCE_RADIUS": 40})
    airborne(f)
    assert goto(f, 20, 0, -10) is True
    f.until(lambda: np.linalg.norm(f.ap.pos[:2] - [20, 0]) < 0.5, 30, "inside goal")
    assert goto(f, 60, 0, -10) is False                 # outside: refused, previous target kept
    f.step(15.0)
    far = max(np.linalg.norm(p[:2] - f.ap.home[:2]) for _, p, _, _ in f.track)
    assert far < 40.0
    assert np.linalg.norm(f.ap.pos[:2] - [20, 0]) < 0.5
    assert f.ap.mode == modes.GUIDED
    assert not any("breached" in m for m in f.said())


def test_guided_goal_outside_an_inclusion_polygon_is_ignored():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 4})
    f.fence([f.at(n, e, 0, POLY_IN, frame=C.MAV_FRAME_GLOBAL_INT, mission_type=1, param1=4)
             for n, e in [(-30, -30), (30, -30), (30, 30), (-30, 30)]])
    airborne(f)
    assert goto(f, 25, 25, -10) is True
    assert goto(f, 35, 0, -10) is False
    f.step(12.0)
    assert np.linalg.norm(f.ap.pos[:2] - [25, 25]) < 0.6


def test_a_breach_in_guided_says_so_and_returns_home():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 3, "FENCE_RADIUS": 30})
    airborne(f)
    # a velocity target is not a destination: nothing refuses it, the fence triggers instead
    f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [4, 0, 0], [0, 0, 0], 0, 0)
    for _ in range(40):                                  # keep the velocity target alive
        f.step(0.5)
        if f.ap.mode != modes.GUIDED:
            break
        f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [4, 0, 0], [0, 0, 0], 0, 0)
    assert "Circle fence breached" in f.said()
    assert f.ap.mode == modes.RTL                         # FENCE_ACTION 1: RTL
    assert max(np.linalg.norm(p[:2]) for _, p, _, _ in f.track) < 30 + 5
    f.until(lambda: not f.ap.armed, 90, "RTL landing")
    assert np.linalg.norm(f.ap.pos[:2] - f.ap.home[:2]) < 1.0


def test_a_max_altitude_breach_with_land_action_lands():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 1, "FENCE_ALT_MAX": 12, "FENCE_ACTION": 2})
    airborne(f, alt=10.0)
    assert goto(f, 0, 0, -20) is False                  # above FENCE_ALT_MAX: refused
    f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [0, 0, -2], [0, 0, 0], 0, 0)
    f.until(lambda: f.ap.mode == modes.LAND, 10, "fence LAND")
    assert "Max Alt fence breached" in f.said()


def test_prearm_refuses_an_enabled_fence_with_nothing_to_check():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 4})
    f.until(lambda: f.ap.home is not None, 30, "home")
    assert f.ap.arm() == C.MAV_RESULT_FAILED
    assert "PreArm: Fences enabled, but none selected" in f.said()
    assert f.ap.command(C.MAV_CMD_DO_FENCE_ENABLE, [0, 0, 0, 0, 0, 0, 0]) == C.MAV_RESULT_ACCEPTED
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED


def test_rover_fence_breach_returns_it_home():
    f = Flight("rover", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 2, "FENCE_RADIUS": 30})
    f.settle()
    assert f.ap.set_mode(modes.ROVER_GUIDED) and f.ap.arm() == C.MAV_RESULT_ACCEPTED
    for _ in range(40):
        f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [4, 0, 0], [0, 0, 0], 0, 0)
        f.step(0.5)
        if f.ap.mode != modes.ROVER_GUIDED:
            break
    assert "Circle fence breached" in f.said() and f.ap.mode == modes.ROVER_RTL
    f.until(lambda: "Reached destination" in f.said(), 60, "rover RTL")


def test_rtl_lands_at_the_nearest_rally_point():
    f = Flight("copter")
    f.rally([f.at(55, 10, 15, C.MAV_CMD_NAV_RALLY_POINT, mission_type=2),
             f.at(-80, 0, 15, C.MAV_CMD_NAV_RALLY_POINT, mission_type=2)])
    airborne(f)
    assert goto(f, 60, 0, -10)
    f.until(lambda: np.linalg.norm(f.ap.pos[:2] - [60, 0]) < 0.5, 40, "out at 60 m")
    assert f.ap.set_mode(modes.RTL)
    f.until(lambda: not f.ap.armed, 90, "RTL to the rally point")
    assert np.linalg.norm(f.ap.pos[:2] - [55, 10]) < 1.0


def test_rtl_goes_home_when_home_is_nearer_than_any_rally_point():
    f = Flight("copter")
    f.rally([f.at(120, 0, 15, C.MAV_CMD_NAV_RALLY_POINT, mission_type=2)])
    airborne(f)
    assert goto(f, 20, 0, -10)
    f.until(lambda: np.linalg.norm(f.ap.pos[:2] - [20, 0]) < 0.5, 30, "out at 20 m")
    assert f.ap.set_mode(modes.RTL)
    f.until(lambda: not f.ap.armed, 90, "RTL home")
    assert np.linalg.norm(f.ap.pos[:2] - f.ap.home[:2]) < 1.0


def test_sys_status_geofence_bits_follow_the_fence():
    """SYS_STATUS as ArduPilot fills it: geofence present when a fence type is configured,
    enabled with FENCE_ENABLE (and an action), healthy until a breach."""
    f = Flight("copter", params={"FENCE_TYPE": 2, "FENCE_RADIUS": 30})
    G = C.MAV_SYS_STATUS_GEOFENCE
    s = f.v.link.telemetry.sys_status()
    assert s.onboard_control_sensors_present & G and not s.onboard_control_sensors_enabled & G
    assert s.onboard_control_sensors_health & G
    f.ap.params.set("FENCE_ENABLE", 1, save=False)
    airborne(f)
    for _ in range(40):                                  # a velocity target lives GUID_TIMEOUT: renew it
        f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [4, 0, 0], [0, 0, 0], 0, 0)
        f.step(0.5)
        if f.ap.fence.breaches:
            break
    s = f.v.link.telemetry.sys_status()
    assert s.onboard_control_sensors_enabled & G and not s.onboard_control_sensors_health & G


def test_prearm_checks_the_fence_altitudes_and_margin_in_ac_fences_words():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 1, "FENCE_ALT_MAX": 20, "FENCE_ALT_MIN": 30})
    f.until(lambda: f.ap.home is not None, 30, "home")
    assert f.ap.arm() == C.MAV_RESULT_FAILED and f.said()[-1] == "PreArm: FENCE_ALT_MAX < FENCE_ALT_MIN"
    f.ap.params.set("FENCE_ALT_MIN", 15, save=False)
    f.ap.params.set("FENCE_MARGIN", 3, save=False)
    assert f.ap.arm() == C.MAV_RESULT_FAILED and f.said()[-1] == "PreArm: FENCE_MARGIN too big"
    f.ap.params.set("FENCE_ALT_MIN", -10, save=False)
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED


def test_min_alt_fence_arms_itself_above_the_floor_and_a_descent_below_it_breaches():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 8, "FENCE_ALT_MIN": 5, "FENCE_ACTION": 0})
    airborne(f, alt=10.0)                            # armed on the ground below the floor: allowed
    assert "Min Alt fence enabled (auto enable)" in f.said()
    assert goto(f, 0, 0, -3) is False                # below FENCE_ALT_MIN: refused
    for _ in range(30):                              # descend at 1 m/s (renewed within GUID_TIMEOUT)
        f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, VEL_ONLY, [0, 0, 0], [0, 0, 1.0], [0, 0, 0], 0, 0)
        f.step(0.5)
        if "Min Alt fence breached" in f.said():
            break
    assert "Min Alt fence breached" in f.said()
    assert f.ap.home[2] - f.ap.pos[2] < 5.0 + 0.2
    assert f.ap.mode == modes.GUIDED                 # FENCE_ACTION 0: report only


def test_landing_goes_through_the_min_alt_fence_without_a_breach():
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 8, "FENCE_ALT_MIN": 5})
    airborne(f, alt=10.0)
    assert f.ap.fence.floor_enabled
    assert f.ap.set_mode(modes.LAND)
    f.until(lambda: not f.ap.armed, 60, "landed")
    assert not any("breached" in m for m in f.said())
    assert f.ap.mode == modes.LAND
