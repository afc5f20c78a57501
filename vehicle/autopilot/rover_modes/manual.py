"""MANUAL (Rover/mode_manual.cpp ModeManual): the pilot's throttle and steering, passed through.

Sticks (rover_pilot.manual): the throttle a fraction of the top speed, the steering a fraction
of the turn-rate limit. No RC input: both neutral, so the rover stays stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes, rover_pilot
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeManual(RoverMode):
    number = modes.ROVER_MANUAL
    position_required, velocity_required, manual_input = False, False, True

    def drive(self, dt: float) -> None:
        self.drive_sticks(rover_pilot.manual)
