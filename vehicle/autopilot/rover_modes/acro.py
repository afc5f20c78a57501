"""ACRO (Rover/mode_acro.cpp ModeAcro): the pilot's speed and turn rate, held by the controllers.

Sticks (rover_pilot.acro): throttle x SPEED_MAX, steering x ACRO_TURN_RATE. No RC input:
target speed 0 and no turn, so the rover stops and stays stopped. It needs a velocity
estimate unless the rover is skid-steered (towerlink's rovers steer).
"""
from __future__ import annotations

from vehicle.autopilot import modes, rover_pilot
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeAcro(RoverMode):
    number = modes.ROVER_ACRO
    position_required, velocity_required, manual_input = False, True, True

    def drive(self, dt: float) -> None:
        self.drive_sticks(rover_pilot.acro)
