"""LAND (ArduCopter/mode_land.cpp ModeLand): descends over the point where it was entered.

Descent at WPNAV_SPEED_DN (or LAND_SPEED_HIGH) above LAND_ALT_LOW, LAND_SPEED below
(copter_mode.CopterMode.land_run); disarms once landed. Says "Landing" on entry.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode


class ModeLand(CopterMode):
    number = modes.LAND
    arming_allowed, autopilot_mode = False, True
    disarm_on_land = True

    def requires_position(self) -> bool:
        """ArduCopter's LAND does not: without a position estimate it descends level
        (ModeLand::nogps_run), as copter_mode.land_run does."""
        return False

    def is_landing(self) -> bool:
        return True

    def enter(self) -> None:
        super().enter()
        self.ap.text(mav.MAV_SEVERITY_INFO, "Landing")

    def fly(self, dt: float) -> None:
        self.land_run(dt)
