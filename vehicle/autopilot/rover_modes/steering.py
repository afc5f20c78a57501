"""STEERING (Rover/mode_steering.cpp ModeSteering): the pilot's speed and lateral acceleration.

Sticks (rover_pilot.steering): throttle x SPEED_MAX, steering x TURN_MAX_G of lateral
acceleration. No RC input: target speed 0 and no turn, so the rover stops and stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes, rover_pilot
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeSteering(RoverMode):
    number = modes.ROVER_STEERING
    position_required, velocity_required, manual_input = False, True, True

    def drive(self, dt: float) -> None:
        self.drive_sticks(rover_pilot.steering)
