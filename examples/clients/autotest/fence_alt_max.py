#!/usr/bin/env python3
"""FENCE_ENABLE 1 with FENCE_TYPE 1 (maximum altitude) at FENCE_ALT_MAX 15 and FENCE_ACTION 1:
climbing past it in GUIDED breaches the fence and ArduCopter switches to RTL and lands
(autotest's fence tests)."""
from helpers import run


def test(v):
    v.set_parameter("FENCE_TYPE", 1)
    v.set_parameter("FENCE_ALT_MAX", 15)
    v.set_parameter("FENCE_ACTION", 1)
    v.set_parameter("FENCE_ENABLE", 1)
    v.takeoff(10)
    v.fly_guided_to_local(0, 0, 25)
    v.wait_mode("RTL", timeout=40)
    v.wait_disarmed(timeout=120)


run(test)
