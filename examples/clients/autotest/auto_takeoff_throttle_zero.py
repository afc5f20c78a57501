#!/usr/bin/env python3
"""The same mission with AUTO_OPTIONS 0: armed in GUIDED on the ground with the throttle at zero
(no pilot), AUTO is entered but ArduCopter's takeoff waits for auto-armed (throttle raised),
so the copter stays on the ground and disarms itself after DISARM_DELAY."""
import time

from helpers import mavlink, run

HOME = (-35.363261, 149.165230)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT


def test(v):
    v.set_parameter("AUTO_OPTIONS", 0)
    v.upload_items([
        (mavlink.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 0, HOME[0], HOME[1], 0),
        (mavlink.MAV_CMD_NAV_TAKEOFF, REL, 0, 0, 0, 0, 0, 0, 10),
        (mavlink.MAV_CMD_NAV_WAYPOINT, REL, 0, 0, 0, 0, HOME[0] + 0.0002, HOME[1], 10),
    ])
    v.wait_ready_to_arm()
    v.change_mode("GUIDED")
    v.arm_vehicle()
    v.change_mode("AUTO")
    end = time.time() + 8
    while time.time() < end:
        if v.altitude() > 1:
            raise AssertionError("took off without the throttle raised")
    v.wait_disarmed(timeout=30)


run(test)
