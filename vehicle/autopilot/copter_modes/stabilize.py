"""STABILIZE (ArduCopter/mode_stabilize.cpp ModeStabilize): the pilot's angles and throttle.

With the sticks centred and no throttle stick simulated: level attitude (zero horizontal
acceleration) at constant altitude, yaw held; the copter drifts with whatever momentum it has.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget


class ModeStabilize(CopterMode):
    number = modes.STABILIZE
    position_required, arming_allowed, manual_throttle = False, True, True

    def fly(self, dt: float) -> None:
        ap = self.ap
        ap.setpoint(level=True, yaw=ap.hold_yaw)
        ap.echo = GuidedTarget("acc", None, None, np.zeros(3), ap.hold_yaw, None)
