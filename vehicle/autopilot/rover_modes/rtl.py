"""RTL (Rover/mode_rtl.cpp ModeRTL): drives home, or to the nearest rally point.

Destination by rally.py (RALLY_LIMIT_KM, RALLY_INCL_HOME); inside WP_RADIUS (+ 0.5 m) it says
"Reached destination" and holds there. AUTO's NAV_RETURN_TO_LAUNCH drives this same object
(start(), drive(), complete()).
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.mission_store import RALLY
from vehicle.autopilot.rally import best_return, rally_points
from vehicle.autopilot.rover_modes.rover_mode import RoverMode

ARRIVE_MARGIN_M = 0.5     # m beyond WP_RADIUS still counts as arrived


class ModeRTL(RoverMode):
    number = modes.ROVER_RTL
    radio_failsafe_acts = False
    arming_allowed, autopilot_mode = False, True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.done = False
        self.dest = np.zeros(3)

    def enter(self) -> None:
        self.start()

    def start(self) -> None:
        """Choose the destination (home or a rally point) from here."""
        ap = self.ap
        ap.refresh()
        self.done = False
        home = ap.home if ap.home is not None else ap.start_ned
        pts = rally_points(ap.missions.items(RALLY), ap.origin, float(home[2]))
        self.dest, _ = best_return(ap.pos, home, pts, float(ap.params.get("RALLY_LIMIT_KM", 0.5)),
                                   int(ap.params.get("RALLY_INCL_HOME", 1)) == 1)

    def complete(self) -> bool:
        return self.done

    def drive(self, dt: float) -> None:
        ap = self.ap
        dest = self.dest
        if not self.done and np.linalg.norm(ap.pos[:2] - dest[:2]) < float(ap.params.get("WP_RADIUS", 2)) + ARRIVE_MARGIN_M:
            self.done = True
            ap.text(mav.MAV_SEVERITY_INFO, "Reached destination")
            ap.hold_here()
        if self.done:
            self.stop()
        else:
            self.drive_to(dest)
