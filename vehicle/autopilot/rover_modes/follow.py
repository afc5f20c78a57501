"""FOLLOW (Rover/mode_follow.cpp ModeFollow): drives after another vehicle (AP_Follow).

The velocity is the lead's plus FOLL_POS_P times the offset error (follow_mode.py), within
WP_SPEED (else CRUISE_SPEED, or DO_CHANGE_SPEED's); no valid lead: stop. Refused without a
word unless FOLL_ENABLE = 1.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.rover_modes.rover_mode import RoverMode

STILL_M_S = 0.05          # a follow velocity below this is a stop


class ModeFollow(RoverMode):
    number = modes.ROVER_FOLLOW
    autopilot_mode = True

    def init(self, ignore_checks: bool) -> bool:
        return self.ap.follow.enabled()

    def drive(self, dt: float) -> None:
        ap = self.ap
        p = ap.params
        speed = float(p.get("WP_SPEED", 0)) or float(p.get("CRUISE_SPEED", 8))
        if ap.speed.override:
            speed = ap.speed.override
        cmd = ap.follow.command(ap.t, ap.pos, speed, float(p.get("ATC_ACCEL_MAX", 2.0)) or 2.0, None)
        if cmd is None or np.hypot(cmd.vel[0], cmd.vel[1]) < STILL_M_S:
            self.stop()
            return
        ap.setpoint(vel=cmd.vel)
        ap.echo = GuidedTarget("vel", None, cmd.vel, None, None, None)
