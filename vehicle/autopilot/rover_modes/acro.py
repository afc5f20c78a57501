"""ACRO (Rover/mode_acro.cpp ModeAcro): the pilot's speed and turn rate, held by the controllers.

No RC: target speed 0 and no turn, so the rover stops and stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeAcro(RoverMode):
    number = modes.ROVER_ACRO

    def requires_position(self) -> bool:
        return False

    def requires_velocity(self) -> bool:
        """ArduRover: only for a rover that is not skid-steered (towerlink's steers)."""
        return True

    def has_manual_input(self) -> bool:
        return True

    def drive(self, dt: float) -> None:
        self.stop()
