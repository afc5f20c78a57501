"""FOLLOW (ArduCopter/mode_follow.cpp ModeFollow): follows another vehicle (AP_Follow).

The velocity is the lead's plus FOLL_POS_P times the offset error, within WPNAV_SPEED,
WPNAV_ACCEL and the climb/descent limits (vehicle/autopilot/follow_mode.py); yaw by
FOLL_YAW_BEHAVE. No valid lead: stop and hold. Refused unless FOLL_ENABLE = 1 ("Set
FOLL_ENABLE = 1").
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget


class ModeFollow(CopterMode):
    number = modes.FOLLOW
    position_required, arming_allowed, autopilot_mode = True, False, True
    reports_guided_enabled = True

    def init(self, ignore_checks: bool) -> bool:
        if not self.ap.follow.enabled():
            self.ap.text(mav.MAV_SEVERITY_WARNING, "Set FOLL_ENABLE = 1")
            return False
        return True

    def fly(self, dt: float) -> None:
        ap = self.ap
        p = ap.params
        cmd = ap.follow.command(ap.t, ap.pos, float(p.get("WPNAV_SPEED", 500)) / 100.0,
                                float(p.get("WPNAV_ACCEL", 250)) / 100.0,
                                (float(p.get("WPNAV_SPEED_UP", 250)) / 100.0,
                                 float(p.get("WPNAV_SPEED_DN", 150)) / 100.0))
        if cmd is None:
            ap.setpoint(yaw=ap.hold_yaw)
            ap.echo = GuidedTarget("vel", None, np.zeros(3), None, ap.hold_yaw, None)
            return
        if cmd.yaw is not None:
            ap.hold_yaw = cmd.yaw
        ap.setpoint(vel=cmd.vel, yaw=ap.hold_yaw)
        ap.echo = GuidedTarget("vel", None, cmd.vel, None, ap.hold_yaw, None)
