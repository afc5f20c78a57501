"""LOITER (ArduCopter/mode_loiter.cpp ModeLoiter): holds position, the pilot's sticks move it.

Sticks centred: holds the point where it was entered (or where it last armed or stopped).
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode


class ModeLoiter(CopterMode):
    number = modes.LOITER
    position_required, arming_allowed, user_takeoff = True, True, True
    reports_guided_enabled = True

    def fly(self, dt: float) -> None:
        ap = self.ap
        ap.setpoint(pos=ap.hold_pos, yaw=ap.hold_yaw)
