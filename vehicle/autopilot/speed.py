"""MAV_CMD_DO_CHANGE_SPEED's horizontal speed: an override of the vehicle's speed parameter
that lasts until cleared (-1, or entering AUTO), as ArduPilot keeps it out of the saved
parameters. The copter's is WPNAV_SPEED (cm/s), the rover's WP_SPEED (m/s); the fleet is
given the override, or the parameter again once it is cleared.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mav


class SpeedOverride:
    """`param` is the speed parameter, `per_m_s` its units per m/s, `default` its value when
    unset; speeds above `max_speed` (m/s) are refused."""

    def __init__(self, params, push_params: Callable[[dict], None], param: str, per_m_s: float,
                 default: float, max_speed: float) -> None:
        self.params = params
        self.push_params = push_params
        self.param, self.per_m_s, self.default = param, per_m_s, default
        self.max_speed = max_speed
        self.override: float | None = None          # m/s

    def change(self, speed: float) -> int:
        """DO_CHANGE_SPEED's param2 (m/s): > 0 sets, -1 clears -> MAV_RESULT."""
        if not math.isfinite(speed) or speed > self.max_speed:
            return mav.MAV_RESULT_FAILED
        if speed == -1:
            self.clear()
            return mav.MAV_RESULT_ACCEPTED
        if speed > 0:
            self.set(float(speed))
            return mav.MAV_RESULT_ACCEPTED
        return mav.MAV_RESULT_FAILED

    def set(self, speed: float) -> None:
        self.override = speed
        self.apply()

    def clear(self) -> None:
        self.override = None
        self.apply()

    def apply(self) -> None:
        """Give the fleet the speed in force."""
        if self.override is not None:
            value = self.override * self.per_m_s
        else:
            value = float(self.params.get(self.param, self.default))
        self.push_params({self.param: value})
