#!/usr/bin/env python3
"""Take off to 20 m, fly 40 m north in GUIDED, then autotest's do_RTL: RTL climbs to RTL_ALT,
flies home, lands and disarms."""
from helpers import run


def test(v):
    v.set_parameter("RTL_ALT", 2500)
    v.takeoff(20)
    v.fly_guided_to_local(40, 0, 20)
    v.wait_until("GLOBAL_POSITION_INT", lambda p: v.distance_from_home() > 38, 60, "40 m out")
    v.change_mode("RTL")
    v.wait_altitude(24, 27, timeout=30)
    v.wait_until("GLOBAL_POSITION_INT", lambda p: v.distance_from_home() < 2, 60, "home")
    v.wait_altitude(-1, 0.5, timeout=90)
    v.wait_disarmed(timeout=60)


run(test)
