#!/usr/bin/env python3
"""Upload a rally point 60 m north of home; from 50 m north, RTL goes to the rally point
(nearer than home, RALLY_INCL_HOME 1) and lands there (autotest's rally tests)."""
from helpers import mavlink, run

HOME = (-35.363261, 149.165230)
RALLY = (HOME[0] + 60 / 111319.5, HOME[1])


def test(v):
    v.set_parameter("RALLY_INCL_HOME", 1)
    result = v.upload_items([(mavlink.MAV_CMD_NAV_RALLY_POINT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                              0, 0, 0, 0, RALLY[0], RALLY[1], 15)], mission_type=mavlink.MAV_MISSION_TYPE_RALLY)
    if result != mavlink.MAV_MISSION_ACCEPTED:
        raise AssertionError(f"rally upload {result}")
    v.takeoff(15)
    v.fly_guided_to_local(50, 0, 15)
    v.wait_until("GLOBAL_POSITION_INT", lambda p: v.distance_from_home() > 48, 60, "50 m out")
    v.change_mode("RTL")
    v.wait_disarmed(timeout=120)
    d = v.distance_from_home()
    v.progress(f"landed {d:.1f} m from home")
    if abs(d - 60) > 3:
        raise AssertionError(f"landed {d:.1f} m from home, the rally point is 60 m")


run(test)
