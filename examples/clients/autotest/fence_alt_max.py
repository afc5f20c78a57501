#!/usr/bin/env python3
"""FENCE_ENABLE 1 with FENCE_TYPE 1 (maximum altitude) at FENCE_ALT_MAX 15 and FENCE_ACTION 1:
climbing past it breaches the fence and ArduCopter switches to RTL and lands (autotest's fence
tests). The climb is a GUIDED velocity target: a GUIDED position above the fence would be
refused (ArduCopter checks GUIDED destinations against the fence), a velocity is not."""
import time

from helpers import mavlink, run


def climb(v, rate):
    m = v.mav
    m.mav.set_position_target_local_ned_send(0, m.target_system, m.target_component, mavlink.MAV_FRAME_LOCAL_NED,
                                             0b110111000111, 0, 0, 0, 0, 0, -rate, 0, 0, 0, 0, 0)


def test(v):
    v.set_parameter("FENCE_TYPE", 1)
    v.set_parameter("FENCE_ALT_MAX", 15)
    v.set_parameter("FENCE_ACTION", 1)
    v.set_parameter("FENCE_ENABLE", 1)
    v.takeoff(10)
    end = time.time() + 40
    while time.time() < end:
        climb(v, 2.0)
        if v.mode_name() == "RTL":
            break
    v.wait_mode("RTL", timeout=5)
    v.wait_disarmed(timeout=120)


run(test)
