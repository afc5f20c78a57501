"""ALT_HOLD (ArduCopter/mode_althold.cpp ModeAltHold): the pilot's angles, automatic throttle.

Sticks: lean angles up to ANGLE_MAX, the yaw stick's rate, the throttle stick a climb rate
(PILOT_SPEED_UP / PILOT_SPEED_DN, THR_DZ about mid stick, slewed at PILOT_ACCEL_Z); on the
ground a climb takes off. Sticks centred (or no RC input): level attitude (roll/pitch 0)
and climb rate 0, so the altitude is held and the copter drifts horizontally with what
momentum it has.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget

NAN = float("nan")


class ModeAltHold(CopterMode):
    number = modes.ALT_HOLD
    position_required, arming_allowed, pilot_takeoff = False, True, True

    def has_user_takeoff(self, must_navigate: bool) -> bool:
        """Only a takeoff the pilot may steer (it holds no position)."""
        return not must_navigate

    def fly(self, dt: float) -> None:
        ap = self.ap
        z, vz = self.pilot.vertical(dt)
        roll, pitch = self.pilot.lean()
        rate = self.pilot.yaw(dt)
        if roll == pitch == rate == vz == 0.0:
            ap.echo = GuidedTarget("acc", None, None, np.zeros(3), ap.hold_yaw, None)
            ap.setpoint(pos=np.array([NAN, NAN, z]), level=True, yaw=ap.hold_yaw)
            return
        self.fly_pilot_angles(z, vz, roll, pitch, rate)
