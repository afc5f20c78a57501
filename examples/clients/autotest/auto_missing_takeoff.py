#!/usr/bin/env python3
"""A mission of waypoints only; armed in GUIDED on the ground, AUTO is refused with
"Auto: Missing Takeoff Cmd" and the mode stays GUIDED (ArduCopter mode_auto.cpp init)."""
from helpers import mavlink, run

HOME = (-35.363261, 149.165230)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT


def test(v):
    v.upload_items([
        (mavlink.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 0, HOME[0], HOME[1], 0),
        (mavlink.MAV_CMD_NAV_WAYPOINT, REL, 0, 0, 0, 0, HOME[0] + 0.0002, HOME[1], 10),
    ])
    v.wait_ready_to_arm()
    v.change_mode("GUIDED")
    v.arm_vehicle()
    result = v.run_cmd(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 3, want_result=None)
    v.progress(f"DO_SET_MODE AUTO result {result}")
    v.wait_statustext("Missing Takeoff Cmd", timeout=5)
    if result == mavlink.MAV_RESULT_ACCEPTED:
        raise AssertionError("AUTO accepted")
    if v.mode_name() != "GUIDED":
        raise AssertionError(f"mode {v.mode_name()}")
    v.run_cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)


run(test)
