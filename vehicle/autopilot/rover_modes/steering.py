"""STEERING (Rover/mode_steering.cpp ModeSteering): the pilot's speed and lateral acceleration.

No RC: target speed 0 and no turn, so the rover stops and stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeSteering(RoverMode):
    number = modes.ROVER_STEERING
    position_required, velocity_required, manual_input = False, True, True

    def drive(self, dt: float) -> None:
        self.stop()
