"""What `towerlink fly` tells while a run flies: the tower's goal progress, the speedup the
machine delivers, and the progress line.

Pure apart from the wall clock, which is passed in (time.monotonic by default).
"""
from __future__ import annotations

import math
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from common.mavlink.lockstep import speedup_text

GOAL_EVENT = re.compile(r"goal (\d+)/(\d+) (sent|reached|FAILED)")
GOAL_SENT = re.compile(r"goal \d+/\d+ sent: \w+ \[([^\]]+)\] at t=([-\d.]+) s")
#: the tower's last line (gcs.tower, gcs.tower_family): its result is written, only its exit is left
MISSION_OVER = re.compile(r"\bMISSION (OK|FAILED): ")
WAITING = {"sim": 0.0, "drone": None, "follow_err": None}     # a snapshot before anything was heard


@dataclass
class GoalState:
    """The mission as the tower's output tells it."""
    n: int = 0                  # the goal the tower spoke of last (1-based; 0: none yet)
    total: int | None = None    # goals in the mission (None: not said yet)
    reached: int = 0            # the last goal reached
    last: str = ""              # what happened to goal n: sent, reached or FAILED
    count: int = 0              # goals reached so far (a family: every drone's)


class TowerOutput:
    """The tower's output, line by line: every line kept, the goal state followed."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.goals = GoalState()
        self.over = threading.Event()      # set by the tower's last line (MISSION OK / FAILED)

    def feed(self, line: str) -> tuple[float, tuple[float, float, float]] | None:
        """Take one line (no newline). Returns (sim time s, goal x, y, z in the tower frame, m)
        when the line says a goal was sent, else None."""
        self.lines.append(line)
        if MISSION_OVER.search(line):
            self.over.set()
        m = GOAL_EVENT.search(line)
        if m:
            n, total, what = int(m.group(1)), int(m.group(2)), m.group(3)
            self.goals.n, self.goals.total, self.goals.last = n, total, what
            if what == "reached":
                self.goals.reached = n
                self.goals.count += 1
        g = GOAL_SENT.search(line)
        if g:
            try:
                p = tuple(float(v) for v in g.group(1).split(","))
                return float(g.group(2)), (p + (0.0, 0.0, 0.0))[:3]
            except ValueError:
                return None
        return None


def goal_text(goals: GoalState, family_goals: int | None = None) -> str:
    """The progress line's goal column; `family_goals`: every drone's goals, counted together."""
    if family_goals is not None:
        return f"goals {goals.count}/{family_goals} reached"
    return f"goal {goals.n}/{goals.total} {goals.last}" if goals.total else "goal -/- (preparing)"


def progress_line(snap: dict, goal: str, achieved: float | None, asked: float, lockstep: bool) -> str:
    """One progress line: sim time s, the goal column, the drone's world NED position m, the
    rover's follow error m, the speedup achieved and the one asked (inf: max)."""
    d = snap["drone"]
    dtxt = f"drone [{d[0]:7.2f}, {d[1]:7.2f}, {d[2]:6.2f}]" if d else "drone [waiting]"
    e = snap["follow_err"]
    etxt = f"rover err {e:5.2f} m" if e is not None else "rover err   -  "
    sptxt = f"{achieved:.1f}x" if achieved else "-"
    asked_txt = speedup_text(asked) + ("" if math.isinf(asked) else "x")
    return (f"[fly] t={snap['sim']:7.2f} s sim  {goal:<20} {dtxt}  {etxt}  "
            f"speedup {sptxt} (asked {asked_txt}{', lockstep' if lockstep else ''})")


class SpeedupMeter:
    """Sim seconds per wall second, from when the sim clock first moved."""

    MIN_WALL_S = 0.5        # no figure before this much wall time: it would be noise

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.anchor: tuple[float, float] | None = None     # (sim s, wall s) when the sim clock first moved

    def update(self, sim: float) -> float | None:
        """Take the newest sim time (s); the speedup so far, None until the clock has moved
        and MIN_WALL_S wall seconds have passed since."""
        if self.anchor is None:
            if sim > 0:
                self.anchor = (sim, self.clock())
            return None
        ds, dw = sim - self.anchor[0], self.clock() - self.anchor[1]
        return ds / dw if dw > self.MIN_WALL_S else None

    def overall(self, sim: float) -> float | None:
        """The speedup from the anchor to sim time `sim` (s), for the summary; None if the
        clock never moved."""
        if self.anchor is None:
            return None
        return (sim - self.anchor[0]) / max(1e-6, self.clock() - self.anchor[1])


class ProgressReporter:
    """Decides the progress lines: at most one every `every` wall seconds, and one only when
    the run moved on since the last (sim time, goal, positions; a world still starting says it
    is waiting once). `every` None: no lines."""

    def __init__(self, asked: float, lockstep: bool, every: float | None = 1.0,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.asked, self.lockstep, self.every, self.clock = asked, lockstep, every, clock
        self._last_at = -math.inf
        self._last_state: tuple | None = None

    def due(self) -> bool:
        """May a line be printed now? (the caller then takes a snapshot for :meth:`line`)"""
        return bool(self.every) and self.clock() - self._last_at >= self.every

    def line(self, snap: dict, goal: str, achieved: float | None) -> str | None:
        """The line to print now, or None."""
        if not self.every:
            return None
        now = self.clock()
        if now - self._last_at < self.every:
            return None
        self._last_at = now
        state = (snap["sim"], snap["drone"], snap["follow_err"], goal)
        if state == self._last_state:
            return None
        self._last_state = state
        return progress_line(snap, goal, achieved, self.asked, self.lockstep)
