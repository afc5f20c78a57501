"""LAND (ArduCopter/mode_land.cpp ModeLand): descends over the point where it was entered.

Descent at WPNAV_SPEED_DN (or LAND_SPEED_HIGH) above LAND_ALT_LOW, LAND_SPEED below
(copter_mode.CopterMode.land_run); disarms once landed. Says "Landing" on entry.

A failsafe lands with a pause (events.cpp set_mode_land_with_pause, copter_failsafe.py):
set_land_pause(True) after the change asks a climb rate of 0 (the copter stops and holds its
altitude) until LAND_WITH_DELAY_S after LAND was entered, then the descent starts (ArduCopter
says nothing of it). A failsafe that finds the copter already in LAND pauses only what is left
of that time since it entered.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode

LAND_WITH_DELAY_S = 4.0      # LAND_WITH_DELAY_MS / 1000: a failsafe landing's pause


class ModeLand(CopterMode):
    number = modes.LAND
    arming_allowed, autopilot_mode = False, True
    disarm_on_land = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.land_pause = False
        self.start_t = 0.0             # sim s LAND was entered (land_start_time)

    def set_land_pause(self, pause: bool) -> None:
        """ModeLand::set_land_pause: no descent yet, a climb rate of 0 (a failsafe's)."""
        self.land_pause = pause

    def requires_position(self) -> bool:
        """ArduCopter's LAND does not: without a position estimate it descends level
        (ModeLand::nogps_run), as copter_mode.land_run does."""
        return False

    def is_landing(self) -> bool:
        return True

    def enter(self) -> None:
        super().enter()
        self.start_t = self.ap.t
        self.land_pause = False
        self.ap.text(mav.MAV_SEVERITY_INFO, "Landing")

    def fly(self, dt: float) -> None:
        if self.land_pause and self.ap.t - self.start_t >= LAND_WITH_DELAY_S - 1e-9:
            self.land_pause = False
        self.land_run(dt, pause=self.land_pause)
