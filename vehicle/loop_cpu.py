"""What the world's loop spends its CPU on: stepping (World.step) and the rest (the
lockstep's TICKs and ACKs, the endpoints' reads and writes, the event loop).

CPU of the loop's own thread (time.thread_time: the onboard logs' writer thread is not in
it), from the loop's start (after the lockstep's start at t = 0) to its end; stepping is the
stepping chunks' CPU less what the lockstep's boundaries took inside them (two clock reads
a chunk and two a TICK boundary: nothing per step). The sitl prints `line()` with its stats.
"""
from __future__ import annotations

import time


class LoopCpu:
    def __init__(self) -> None:
        self.total = 0.0            # s: the loop's thread, start to end
        self.stepping = 0.0         # s: in World.step
        self.steps = 0              # steps the loop made
        self._t0: float | None = None
        self._s0 = 0

    def start(self, steps: int) -> None:
        """The loop starts, the world at step `steps`."""
        self._t0, self._s0 = time.thread_time(), steps

    def stop(self, steps: int) -> None:
        """The loop ends, the world at step `steps`."""
        if self._t0 is not None:
            self.total += time.thread_time() - self._t0
            self.steps += steps - self._s0
            self._t0 = None

    def line(self) -> str:
        """One line for the stats: CPU per step in all, stepping, and the rest (us)."""
        if not self.steps:
            return "world loop: no steps"
        per = 1e6 / self.steps
        return (f"world loop: {self.steps} steps, {self.total * per:.1f} us CPU per step "
                f"({self.stepping * per:.1f} stepping, {(self.total - self.stepping) * per:.1f} lockstep, "
                f"endpoints and event loop; the loop's thread)")
