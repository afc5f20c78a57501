"""SMART_RTL (ArduCopter/mode_smart_rtl.cpp ModeSmartRTL): retraces the way it came, lands.

Retraces the SmartRTL breadcrumbs (smartrtl.py: SRTL_ACCURACY, SRTL_POINTS) at WPNAV_SPEED,
goes 2 m above the first point (where it armed) and lands there. The path is recorded while
armed in every other mode (save_position, every tick; the path itself at 3 Hz). Without a usable path the mode refuses
to start ("Mode change to SMART_RTL failed: init failed"). Leaving it part way puts the point
it was flying to back on the path (ModeSmartRTL::exit).
"""
from __future__ import annotations

import numpy as np

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.rtl import ModeRTL
from vehicle.autopilot.guided import GuidedTarget

PRELAND_ABOVE_M = 2.0    # m above the last point before the descent
PRELAND_STILL_M_S = 0.5  # m/s: slow enough there to start landing


class ModeSmartRTL(ModeRTL):
    """RTL's hooks and landing (ArduCopter's ModeSmartRTL is a ModeRTL), its own way back.
    `stage`: path, preland, land."""

    number = modes.SMART_RTL

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.dest: np.ndarray | None = None
        self.popped: np.ndarray | None = None      # taken off the path, not yet reached

    def init(self, ignore_checks: bool) -> bool:
        return self.ap.srtl.usable()

    def enter(self) -> None:
        self.ap.srtl.cleanup()
        self.stage = "path"
        self.dest = None                 # the first point is taken when it flies

    def exit(self) -> None:
        super().exit()
        if self.popped is not None:
            self.ap.srtl.push(self.popped)          # not reached: back on the path
        self.popped = self.dest = None
        self.stage = ""

    def save_position(self, t: float) -> None:
        """Every tick, in any mode: record the path while armed and not retracing it (at 3 Hz:
        vehicle.autopilot.smartrtl.SAVE_RATE)."""
        ap = self.ap
        ap.srtl.record(ap.pos, ap.est_ok, ap.armed, ap.flightmode is self, t)

    def _next(self) -> None:
        ap = self.ap
        p = self.popped = ap.srtl.pop()
        if p is None or not ap.srtl.points:
            # the last point (where it armed): 2 m above it, then land there
            dest = ap.pos.copy() if p is None else p.copy()
            dest[2] -= PRELAND_ABOVE_M
            self.dest = dest
            self.stage = "preland"
        else:
            self.dest = p

    def fly(self, dt: float) -> None:
        ap = self.ap
        if self.stage == "land":
            self.land_run(dt)
            return
        if self.dest is None:
            self._next()
        radius = max(float(ap.params.get("WPNAV_RADIUS", 200)) / 100.0, 0.5)
        dest = self.dest
        if np.linalg.norm(ap.pos - dest) < radius:
            if self.stage == "preland":
                if np.linalg.norm(ap.vel) < PRELAND_STILL_M_S:
                    self.stage = "land"
                    self.popped = None
                    ap.hold_pos = np.array([dest[0], dest[1], ap.pos[2]])
                    self.land_run(dt)
                    return
            else:
                self._next()
                dest = self.dest
        ap.echo = GuidedTarget("pos", dest.copy(), None, None, ap.hold_yaw, None)
        ap.setpoint(pos=dest, yaw=ap.hold_yaw)
