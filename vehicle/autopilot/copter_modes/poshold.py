"""POSHOLD (ArduCopter/mode_poshold.cpp ModePosHold): the pilot's angles, braking to a hold.

Sticks centred: it brakes with PHLD_BRAKE_ANGLE (cdeg) of lean as its deceleration, reached at
PHLD_BRAKE_RATE (deg/s) (stopping.py), then holds the point where it stopped.
"""
from __future__ import annotations

import math

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.copter_modes.stopping import StopThenHold
from vehicle.autopilot.mode import ArmingMethod

GRAVITY = 9.80665


class ModePosHold(CopterMode):
    number = modes.POSHOLD

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.stop = StopThenHold(ap)

    def requires_position(self) -> bool:
        return True

    def allows_arming(self, method: ArmingMethod) -> bool:
        return True

    def has_user_takeoff(self, must_navigate: bool) -> bool:
        return True

    def enter(self) -> None:
        ap = self.ap
        if ap.armed and not ap.on_ground:          # else nothing to stop: hold where it is
            angle = math.radians(float(ap.params.get("PHLD_BRAKE_ANGLE", 3000)) / 100.0)
            rate = math.radians(float(ap.params.get("PHLD_BRAKE_RATE", 8)))
            self.stop.start(GRAVITY * math.tan(angle), GRAVITY * rate)

    def exit(self) -> None:
        super().exit()
        self.stop.release()

    def fly(self, dt: float) -> None:
        self.stop.run(dt)
