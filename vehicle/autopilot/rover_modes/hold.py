"""HOLD (Rover/mode_hold.cpp ModeHold): stopped, throttle and steering neutral."""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeHold(RoverMode):
    number = modes.ROVER_HOLD
    radio_failsafe_acts = False
    position_required, velocity_required = False, False

    def drive(self, dt: float) -> None:
        self.stop()
