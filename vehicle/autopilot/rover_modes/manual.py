"""MANUAL (Rover/mode_manual.cpp ModeManual): the pilot's throttle and steering, passed through.

No RC: both neutral, so the rover stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeManual(RoverMode):
    number = modes.ROVER_MANUAL

    def requires_position(self) -> bool:
        return False

    def requires_velocity(self) -> bool:
        return False

    def has_manual_input(self) -> bool:
        return True

    def drive(self, dt: float) -> None:
        self.stop()
