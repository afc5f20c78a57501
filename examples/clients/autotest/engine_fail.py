#!/usr/bin/env python3
"""SIM_ENGINE_MUL 0 and SIM_ENGINE_FAIL 1 at 30 m: motor 1 stops and the quad cannot hold
itself; it loses attitude and falls (SITL's SIM_ENGINE_* motor failure)."""
import time

from helpers import run


def test(v):
    v.takeoff(30)
    v.set_parameter("SIM_ENGINE_MUL", 0)
    v.set_parameter("SIM_ENGINE_FAIL", 1)
    start = v.altitude()
    end, lowest = time.time() + 20, start
    while time.time() < end and lowest > start - 10:
        lowest = min(lowest, v.altitude())
    v.progress(f"lost {start - lowest:.1f} m")
    if lowest > start - 10:
        raise AssertionError(f"still at {lowest:.1f} m with a dead motor")


run(test)
