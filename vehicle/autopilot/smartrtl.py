"""SmartRTL breadcrumbs as ArduPilot's AP_SmartRTL keeps them (pure: no clock, no I/O).

Positions are world NED metres. The path starts where the vehicle armed (or where its
position first became good), gains a point whenever the vehicle is SRTL_ACCURACY metres from
the last one, and holds at most SRTL_POINTS points. When it fills, the path is cleaned as
ArduPilot cleans it: Ramer-Douglas-Peucker simplification with epsilon = accuracy / 2, then
loop pruning (two non-adjacent segments closer than 0.99 * accuracy: everything between them
is cut). If no point can be added for SMARTRTL_TIMEOUT seconds (path full after cleanup) or
the position stays bad that long, the path is deactivated with ArduPilot's text
"SmartRTL deactivated: <why>"; a deactivated path cannot be flown (SMART_RTL refuses to
start and failsafes fall back to RTL).
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.task_rate import TaskRate

TIMEOUT = 15.0           # s: AP_SmartRTL's SMARTRTL_TIMEOUT
SAVE_RATE = 3.0          # Hz: ModeSmartRTL::save_position's scheduler task (ArduCopter/Copter.cpp, Rover/Rover.cpp)


def _seg_dist(p1, p2, p3, p4) -> tuple[float, np.ndarray]:
    """Closest distance between segments p1p2 and p3p4, and the midpoint of the closest pair."""
    d1, d2, r = p2 - p1, p4 - p3, p1 - p3
    a, e, f = d1 @ d1, d2 @ d2, d2 @ r
    if a < 1e-12 and e < 1e-12:
        return float(np.linalg.norm(r)), 0.5 * (p1 + p3)
    if a < 1e-12:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = d1 @ r
        if e < 1e-12:
            t, s = 0.0, min(max(-c / a, 0.0), 1.0)
        else:
            b = d1 @ d2
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-12 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
    c1, c2 = p1 + d1 * s, p3 + d2 * t
    return float(np.linalg.norm(c1 - c2)), 0.5 * (c1 + c2)


def _point_line_dist(p, a, b) -> float:
    ab = b - a
    n = ab @ ab
    if n < 1e-12:
        return float(np.linalg.norm(p - a))
    t = min(max((p - a) @ ab / n, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + ab * t)))


def simplify(points: list[np.ndarray], epsilon: float) -> list[np.ndarray]:
    """Ramer-Douglas-Peucker: drop points closer than epsilon to the line their neighbours keep."""
    if len(points) < 3:
        return list(points)
    keep = [False] * len(points)
    keep[0] = keep[-1] = True
    stack = [(0, len(points) - 1)]
    while stack:
        i, j = stack.pop()
        best, idx = -1.0, -1
        for k in range(i + 1, j):
            d = _point_line_dist(points[k], points[i], points[j])
            if d > best:
                best, idx = d, k
        if idx >= 0 and best > epsilon:
            keep[idx] = True
            stack += [(i, idx), (idx, j)]
    return [p for p, k in zip(points, keep) if k]


def prune_loops(points: list[np.ndarray], delta: float) -> list[np.ndarray]:
    """Cut every loop: when segment i (points i, i+1) passes within delta of a later,
    non-adjacent segment j, the points i+1..j are replaced by the midpoint of the closest pair."""
    pts = list(points)
    i = 0
    while i < len(pts) - 3:
        for j in range(len(pts) - 2, i + 1, -1):      # furthest loop first: cut the most
            d, mid = _seg_dist(pts[i], pts[i + 1], pts[j], pts[j + 1])
            if d < delta:
                pts = pts[:i + 1] + [mid] + pts[j + 1:]
                break
        i += 1
    return pts


class SmartRTLPath:
    """The breadcrumb path of one vehicle. `text(severity, msg)` reports deactivation."""

    def __init__(self, accuracy: float = 2.0, points_max: int = 300,
                 text: Callable[[int, str], None] | None = None) -> None:
        self.accuracy = float(accuracy)
        self.points_max = int(points_max)
        self.text = text or (lambda sev, msg: None)
        self.points: list[np.ndarray] = []
        self.active = False
        self.home_saved = False
        self.last_save = 0.0
        self.last_good = 0.0
        self.was_armed = False
        self._save_task = TaskRate(SAVE_RATE)
        # SRTL_POINTS 0 or SRTL_ACCURACY 0 disables SmartRTL, as AP_SmartRTL::init
        self.enabled = self.points_max > 0 and self.accuracy > 0

    def set_home(self, pos, t: float) -> None:
        """Clear the path and start it at pos (arming, or the first good position)."""
        if not self.enabled:
            return
        self.points = [np.asarray(pos, float).copy()]
        self.active = self.home_saved = True
        self.last_save = self.last_good = t

    def record(self, pos, position_ok: bool, armed: bool, retracing: bool, t: float) -> None:
        """Every autopilot tick: a new path at every arming (ArduPilot sets it when it arms) or
        at the first good position; at SAVE_RATE (ArduPilot's ModeSmartRTL::save_position, a
        3 Hz scheduler task) pos saved while armed and not retracing the path, and the
        timeouts checked."""
        if armed and not self.was_armed:
            self.set_home(pos, t)
        self.was_armed = armed
        if position_ok and not self.home_saved:
            self.set_home(pos, t)
        if not self._save_task.due(t) or not self.active or not armed or retracing:
            return
        if not position_ok:
            if t - self.last_good > TIMEOUT:
                self.deactivate("bad position")
            return
        self.last_good = t
        if self._add(np.asarray(pos, float)):
            self.last_save = t
        elif t - self.last_save > TIMEOUT:
            self.deactivate("buffer full")

    def _add(self, p: np.ndarray) -> bool:
        # the distance as norm() computes it, sqrt(d.d), without its checks
        if self.points and math.sqrt((d := self.points[-1] - p).dot(d)) < self.accuracy:
            return True
        if len(self.points) >= self.points_max:
            self.cleanup()
            if len(self.points) >= self.points_max:
                return False
        self.points.append(p.copy())
        return True

    def cleanup(self) -> None:
        """Simplify then prune loops (ArduPilot's thorough cleanup); the last point stays."""
        if len(self.points) < 3:
            return
        pts = simplify(self.points, 0.5 * self.accuracy)
        self.points = prune_loops(pts, 0.99 * self.accuracy)

    def deactivate(self, why: str) -> None:
        if self.active:
            self.active = False
            self.text(mav.MAV_SEVERITY_WARNING, f"SmartRTL deactivated: {why}")

    def usable(self) -> bool:
        return self.active and len(self.points) >= 1

    def pop(self) -> np.ndarray | None:
        """The next point home (the newest breadcrumb), removed from the path."""
        return self.points.pop() if self.points else None

    def push(self, p) -> None:
        """Put back a point not reached (leaving SMART_RTL mid-way, as ArduPilot's exit())."""
        self.points.append(np.asarray(p, float).copy())
