"""The commands as a rover takes them (ArduRover's GCS_MAVLINK_Rover), on top of commands.py:
DO_REPOSITION's param1 is the GUIDED speed."""
from __future__ import annotations

from vehicle.autopilot.commands import Commands

MAX_REPOSITION_SPEED = 100.0     # m/s


class RoverCommands(Commands):
    def reposition_speed(self, speed: float | None) -> None:
        """A positive DO_REPOSITION param1 is the GUIDED speed (m/s)."""
        if speed is not None:
            self.ap.speed.set(min(float(speed), MAX_REPOSITION_SPEED))
