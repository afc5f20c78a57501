"""POSHOLD (ArduCopter/mode_poshold.cpp ModePosHold): the pilot's angles, braking to a hold.

Sticks centred: it brakes with PHLD_BRAKE_ANGLE (cdeg) of lean as its deceleration, reached at
PHLD_BRAKE_RATE (deg/s) (stopping.py), then holds the point where it stopped.
"""
from __future__ import annotations

import math

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.stopping import StoppingMode

GRAVITY = 9.80665


class ModePosHold(StoppingMode):
    number = modes.POSHOLD
    position_required, arming_allowed, user_takeoff = True, True, True

    def stop_limits(self) -> tuple[float, float]:
        p = self.ap.params
        angle = math.radians(float(p.get("PHLD_BRAKE_ANGLE", 3000)) / 100.0)
        rate = math.radians(float(p.get("PHLD_BRAKE_RATE", 8)))
        return GRAVITY * math.tan(angle), GRAVITY * rate
