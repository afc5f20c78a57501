"""SMART_RTL (Rover/mode_smart_rtl.cpp ModeSmartRTL): retraces the way it came.

Follows the SmartRTL breadcrumbs (smartrtl.py: SRTL_ACCURACY, SRTL_POINTS) recorded while armed
in other modes (save_position, every tick; the path itself at 3 Hz), says "Reached destination" at the first point
(where it armed) and stops there. Without a usable path the mode refuses to start, as
ModeSmartRTL::_enter; leaving it part way puts the point it was driving to back on the path.
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.rover_modes.rover_mode import RoverMode


class ModeSmartRTL(RoverMode):
    number = modes.ROVER_SMART_RTL
    arming_allowed, autopilot_mode = False, True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.dest: np.ndarray | None = None
        self.done = False

    def init(self, ignore_checks: bool) -> bool:
        return self.ap.srtl.usable()

    def enter(self) -> None:
        self.ap.srtl.cleanup()
        self.done = False
        self.dest = None                 # the first point is taken when it drives

    def exit(self) -> None:
        if not self.done and self.dest is not None:
            self.ap.srtl.push(self.dest)
        self.dest = None

    def save_position(self, t: float) -> None:
        """Every tick, in any mode: record the path while armed and not retracing it (at 3 Hz:
        vehicle.autopilot.smartrtl.SAVE_RATE)."""
        ap = self.ap
        ap.srtl.record(ap.pos, ap.est_ok, ap.armed, ap.flightmode is self, t)

    def drive(self, dt: float) -> None:
        ap = self.ap
        path = ap.srtl
        radius = float(ap.params.get("WP_RADIUS", 2))
        if self.dest is None and not self.done:
            self.dest = path.pop()
        while not self.done and self.dest is not None and np.linalg.norm(ap.pos[:2] - self.dest[:2]) < radius:
            nxt = path.pop()
            if nxt is None:
                self.done = True
                ap.text(mav.MAV_SEVERITY_INFO, "Reached destination")
                ap.hold_here()
            else:
                self.dest = nxt
        if self.done or self.dest is None:
            self.stop()
        else:
            self.drive_to(self.dest)
