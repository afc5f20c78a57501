"""ALT_HOLD (ArduCopter/mode_althold.cpp ModeAltHold): the pilot's angles, automatic throttle.

Sticks centred: level attitude (roll/pitch 0) and climb rate 0, so the altitude at entry is
held and the copter drifts horizontally with what momentum it has.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget

NAN = float("nan")


class ModeAltHold(CopterMode):
    number = modes.ALT_HOLD
    position_required, arming_allowed = False, True

    def has_user_takeoff(self, must_navigate: bool) -> bool:
        """Only a takeoff the pilot may steer (it holds no position)."""
        return not must_navigate

    def fly(self, dt: float) -> None:
        ap = self.ap
        ap.echo = GuidedTarget("acc", None, None, np.zeros(3), ap.hold_yaw, None)
        ap.setpoint(pos=np.array([NAN, NAN, ap.hold_pos[2]]), level=True, yaw=ap.hold_yaw)
