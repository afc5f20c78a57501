"""LOITER (ArduCopter/mode_loiter.cpp ModeLoiter): holds position, the pilot's sticks move it.

Sticks centred: holds the point where it was entered (or where it last armed or stopped).
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.mode import ArmingMethod


class ModeLoiter(CopterMode):
    number = modes.LOITER
    reports_guided_enabled = True

    def requires_position(self) -> bool:
        return True

    def allows_arming(self, method: ArmingMethod) -> bool:
        return True

    def has_user_takeoff(self, must_navigate: bool) -> bool:
        return True

    def fly(self, dt: float) -> None:
        ap = self.ap
        ap.setpoint(pos=ap.hold_pos, yaw=ap.hold_yaw)
