"""A scheduler task's own rate on the autopilot tick, as ArduPilot's AP_Scheduler runs a
SCHED_TASK: not every loop, but once its interval has passed since it last ran.

The autopilot ticks at 50 Hz (vehicle/world.py AP_RATE); a task of `hz` runs at the first tick
and then at each tick at least 1/hz sim s after its last run (within a microsecond: sim
times are step counts times dt, so 0.04 s may come out a rounding under). At 50 Hz a 25 Hz
task runs every 2nd tick, a 10 Hz one every 5th, a 3 Hz one every 17th (2.94 Hz; ArduCopter's
400 Hz loop gives 3.01 Hz).
"""
from __future__ import annotations

import math

_SLACK = 1e-6            # s: a tick's sim time may be a rounding short of the interval


class TaskRate:
    def __init__(self, hz: float) -> None:
        """hz: the task's rate (ArduPilot's scheduler table); it never runs faster than the tick."""
        self.period = 1.0 / hz
        self.last = -math.inf

    def due(self, t: float) -> bool:
        """At the tick of sim time t (s): True when the task runs now (and from now on counts
        from t). A clock that went back (a new world, a test) starts the task afresh."""
        if t < self.last:
            self.last = -math.inf
        if t - self.last >= self.period - _SLACK:
            self.last = t
            return True
        return False
