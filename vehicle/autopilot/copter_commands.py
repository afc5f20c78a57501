"""The commands only a copter takes (ArduCopter's GCS_MAVLINK_Copter), on top of commands.py:
NAV_TAKEOFF (the current mode's user takeoff: GUIDED's), NAV_LAND (LAND), NAV_LOITER_UNLIM
(LOITER) and CONDITION_YAW (GUIDED: face an angle, absolute or relative).
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames.batch import wrap_pi
from vehicle.autopilot import modes
from vehicle.autopilot.commands import DENIED, FAILED, Commands, finite, result

MAX_YAW_RATE_DEG_S = 1080.0     # CONDITION_YAW param2 beyond ATC_RATE_Y_MAX's range: refused


class CopterCommands(Commands):
    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.handlers.update({
            mav.MAV_CMD_NAV_TAKEOFF: self.takeoff,
            mav.MAV_CMD_NAV_LAND: lambda p, frame, x, y: result(ap.set_mode(modes.LAND)),
            mav.MAV_CMD_NAV_LOITER_UNLIM: lambda p, frame, x, y: result(ap.set_mode(modes.LOITER)),
            mav.MAV_CMD_CONDITION_YAW: self.condition_yaw,
        })

    def takeoff(self, p, frame, x, y) -> int:
        """param7: altitude (m above here); param3 0: the mode must hold position meanwhile."""
        return result(self.ap.flightmode.do_user_takeoff(p[6], p[2] == 0))

    def condition_yaw(self, p, frame, x, y) -> int:
        """ArduPilot: angle 0..360 deg and param4 0 (absolute) or 1 (relative; param3 < 0
        counter-clockwise), else DENIED; outside GUIDED, FAILED."""
        if not finite(p, 0, 1, 2, 3) or not 0 <= p[0] <= 360 or not 0 <= p[1] <= MAX_YAW_RATE_DEG_S \
                or p[3] not in (0, 1):
            return DENIED
        ap = self.ap
        if ap.flightmode is not ap.guided:
            return FAILED
        ang = math.radians(p[0])
        if p[3]:
            ang = ap.yaw + (ang if p[2] >= 0 else -ang)
        ap.guided.set_yaw(wrap_pi(ang))
        return result(True)
