"""STABILIZE (ArduCopter/mode_stabilize.cpp ModeStabilize): the pilot's angles and throttle.

Sticks: lean angles up to ANGLE_MAX, the yaw stick's rate (PILOT_Y_RATE), the throttle stick
as the collective (get_pilot_desired_throttle: mid stick is MOT_THST_HOVER); with the throttle
above zero on the ground it spins up and flies, at zero it idles there. Without RC input: level
attitude (zero horizontal acceleration) at constant altitude, yaw held; the copter drifts with
whatever momentum it has.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import copter_pilot, modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget


class ModeStabilize(CopterMode):
    number = modes.STABILIZE
    position_required, arming_allowed, manual_throttle = False, True, True

    def leaves_ground(self) -> bool:
        """The throttle stick above zero spins the motors up (ArduCopter's land detector
        then lets go of the ground)."""
        s = self.pilot.sticks
        return s is not None and s.throttle > 0

    def fly(self, dt: float) -> None:
        ap = self.ap
        s = self.pilot.sticks
        if s is None:
            ap.setpoint(level=True, yaw=ap.hold_yaw)
            ap.echo = GuidedTarget("acc", None, None, np.zeros(3), ap.hold_yaw, None)
            return
        roll, pitch = self.pilot.lean()
        rate = self.pilot.yaw(dt)
        thrust = copter_pilot.throttle(s, float(ap.params.get("MOT_THST_HOVER", 0.45)))
        ap.echo = None
        ap.setpoint(roll=roll, pitch=pitch, yaw=ap.hold_yaw, yaw_rate=rate, thrust=thrust)
