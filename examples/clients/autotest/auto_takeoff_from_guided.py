#!/usr/bin/env python3
"""Upload TAKEOFF 10 m, a waypoint and RTL; with AUTO_OPTIONS bit 1 ("allow takeoff without
raising throttle") arm in GUIDED on the ground and switch to AUTO: the mission's takeoff
flies, then the waypoint and RTL (autotest's AUTO flights, with the option instead of set_rc(3))."""
from helpers import mavlink, run

HOME = (-35.363261, 149.165230)
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT


def test(v):
    v.set_parameter("AUTO_OPTIONS", 2)
    v.upload_items([
        (mavlink.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 0, HOME[0], HOME[1], 0),
        (mavlink.MAV_CMD_NAV_TAKEOFF, REL, 0, 0, 0, 0, 0, 0, 10),
        (mavlink.MAV_CMD_NAV_WAYPOINT, REL, 0, 0, 0, 0, HOME[0] + 0.0002, HOME[1], 10),
        (mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, REL, 0, 0, 0, 0, 0, 0, 0),
    ])
    v.wait_ready_to_arm()
    v.change_mode("GUIDED")
    v.arm_vehicle()
    v.change_mode("AUTO")
    v.wait_altitude(9, 12, timeout=40)
    v.wait_disarmed(timeout=120)


run(test)
