"""MANUAL (Rover/mode_manual.cpp ModeManual): the pilot's throttle and steering, passed through.

No RC: both neutral, so the rover stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeManual(RoverMode):
    number = modes.ROVER_MANUAL
    position_required, velocity_required, manual_input = False, False, True

    def drive(self, dt: float) -> None:
        self.stop()
