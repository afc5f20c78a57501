"""The sweep's progress display: a bar on a terminal, plain lines everywhere else.

On a terminal a tqdm bar stays at the bottom (runs done of the total, failures, runs in
flight, elapsed and ETA) and each finished run's line is printed above it, so the record of
every run stays in the scrollback. When the output is not a terminal (CI, ``| tee``, a log
file) there is no bar and no carriage return: one line per finished run, each carrying the
counts and the ETA itself.

Runs finished before (a resumed sweep) count as done from the start; the ETA is reckoned
from the runs flown in this invocation only.
"""
from __future__ import annotations

import sys
import time
from typing import Callable, TextIO


def require_bar_library() -> None:
    """ImportError unless tqdm is installed. It is drawn only on a terminal, so an install of
    the sweep extra from before tqdm joined it would otherwise fail only after Ray started."""
    import tqdm  # noqa: F401


def fmt_s(s: float) -> str:
    """Seconds as M:SS, or H:MM:SS from an hour."""
    s = max(0, int(round(s)))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


class Progress:
    """Shows a sweep's progress on `stream` (default stdout).

    tty: draw the bar (default: whether `stream` is a terminal). clock: wall seconds
    (time.monotonic; a test passes its own)."""

    def __init__(self, total: int, done: int = 0, failed: int = 0, stream: TextIO | None = None,
                 tty: bool | None = None, clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream if stream is not None else sys.stdout
        self.total, self.done, self.failed = total, done, failed
        self.flown = 0                      # finished in this invocation (the ETA's rate)
        self.in_flight = 0
        self.clock = clock
        self.t0 = clock()
        if tty is None:
            isatty = getattr(self.stream, "isatty", None)
            tty = bool(isatty and isatty())
        self.bar = None
        if tty:
            from tqdm import tqdm       # the sweep extra; only a terminal needs it
            self.bar = tqdm(total=total, initial=done, file=self.stream, unit="run", dynamic_ncols=True,
                            desc="sweep", bar_format="{desc} {bar} {n_fmt}/{total_fmt}{postfix} "
                                                     "[{elapsed}<{remaining}]")
            self._postfix()

    def eta(self) -> float | None:
        """Wall seconds left at this invocation's rate; None before the first run finished."""
        if not self.flown:
            return None
        return (self.clock() - self.t0) / self.flown * (self.total - self.done)

    def started(self, in_flight: int) -> None:
        """How many runs are flying now."""
        self.in_flight = in_flight
        self._postfix()

    def finished(self, what: str, ok: bool, reason: str | None = None, wall_s: float | None = None) -> None:
        """One run ended: `what` names it (its id and factors)."""
        self.done += 1
        self.flown += 1
        self.failed += not ok
        self.in_flight = max(0, self.in_flight - 1)
        res = "pass" if ok else f"FAIL ({reason})"
        took = f", {wall_s:.1f} s" if isinstance(wall_s, (int, float)) else ""
        if self.bar is not None:
            self.bar.write(f"[sweep] {what}: {res}{took}", file=self.stream)
            self.bar.update(1)
            self._postfix()
            return
        eta = self.eta()
        print(f"[sweep] {self.done}/{self.total} done, {self.failed} failed, elapsed "
              f"{fmt_s(self.clock() - self.t0)}, ETA {fmt_s(eta) if eta is not None else '?'} | "
              f"{what}: {res}{took}", file=self.stream, flush=True)

    def note(self, line: str) -> None:
        """A line of its own (above the bar on a terminal)."""
        if self.bar is not None:
            self.bar.write(line, file=self.stream)
        else:
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        """Leave the bar drawn as it ended, the cursor on a fresh line (also after Ctrl-C)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def _postfix(self) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(f"{self.failed} failed, {self.in_flight} flying", refresh=True)
