"""LOITER (Rover/mode_loiter.cpp ModeLoiter): holds the point where it was entered.

Within LOIT_RADIUS of it the rover stops; pushed further away it drives back to the point.
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeLoiter(RoverMode):
    number = modes.ROVER_LOITER
    autopilot_mode = True

    def drive(self, dt: float) -> None:
        ap = self.ap
        if np.linalg.norm(ap.pos[:2] - ap.hold_pos[:2]) <= float(ap.params.get("LOIT_RADIUS", 2)):
            self.stop()
        else:
            self.drive_to(ap.hold_pos)
