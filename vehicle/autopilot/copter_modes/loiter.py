"""LOITER (ArduCopter/mode_loiter.cpp ModeLoiter): holds position, the pilot's sticks move it.

Sticks: roll and pitch a horizontal velocity up to LOIT_SPEED (the square stick range on a
circle, in the copter's heading frame), reached at LOIT_ACC_MAX and given up at
LOIT_BRK_ACCEL; the throttle a climb rate as ALT_HOLD's (a climb on the ground takes off);
the yaw stick turns it. Released, it slows to a stop and holds where it stopped. Sticks
centred (or no RC input): holds the point where it was entered (or where it last armed or
stopped).
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode

NAN = float("nan")


class ModeLoiter(CopterMode):
    number = modes.LOITER
    position_required, arming_allowed, user_takeoff, pilot_takeoff = True, True, True, True
    reports_guided_enabled = True

    def fly(self, dt: float) -> None:
        ap = self.ap
        z, vz = self.pilot.vertical(dt)
        rate = self.pilot.yaw(dt)
        vn, ve = self.pilot.velocity(dt)
        if vn or ve:
            # flown as a velocity; the hold point follows, so a release stops from here
            ap.hold_pos[0], ap.hold_pos[1] = ap.pos[0], ap.pos[1]
            ap.setpoint(pos=np.array([NAN, NAN, z]), vel=np.array([vn, ve, vz]), yaw=ap.hold_yaw,
                        yaw_rate=rate or None)
            return
        if vz:
            ap.setpoint(pos=np.array([ap.hold_pos[0], ap.hold_pos[1], z]), vel=np.array([0.0, 0.0, vz]),
                        yaw=ap.hold_yaw, yaw_rate=rate or None)
            return
        ap.setpoint(pos=ap.hold_pos, yaw=ap.hold_yaw, yaw_rate=rate or None)
