"""The sweep's progress display: one line per finished run, and on a terminal a bar under them.

On a terminal (stream.isatty()) a bar is pinned at the bottom and redrawn in place
(done/total, failed, runs in flight, elapsed, ETA: tqdm draws it), and each finished run's line
is written above it so the record of every run stays in the scrollback. Anywhere else (CI, a pipe,
a log file) only plain lines, one per finished run with the counts in it, no carriage returns.

Pure apart from the stream it writes to and the clock it is given (wall seconds, monotonic), so
tests feed it rows with a fake clock and read a StringIO. tqdm is imported only when a bar is drawn
(it is in the sweep extra, like Ray).
"""
from __future__ import annotations

import sys
import time
from typing import Any, Callable, TextIO


def fmt_s(s: float) -> str:
    """Seconds as M:SS, or H:MM:SS from an hour (rounded, never negative)."""
    s = max(0, int(round(s)))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def result_text(row: dict[str, Any]) -> str:
    """'pass' or 'FAIL (reason)', then the run's wall time when it has one."""
    res = "pass" if row.get("pass") else f"FAIL ({row.get('reason')})"
    wall = row.get("wall_s")
    return res + (f", {wall:.1f} s" if isinstance(wall, (int, float)) and not isinstance(wall, bool) else "")


class Progress:
    """Counts and shows a sweep's runs as they finish.

    total: runs in the sweep; initial: runs already finished (resumed), initial_failed: how many of
    those failed; t0: when the sweep began (clock's seconds; default now). The ETA is this session's mean time per finished run (wall) times the runs left;
    it is '?' until a run finishes. Use as a context manager: the bar is closed on any exit,
    Ctrl-C included, so the terminal is left with the cursor on a fresh line.
    """

    def __init__(self, total: int, initial: int = 0, initial_failed: int = 0, *, stream: TextIO | None = None,
                 tty: bool | None = None, clock: Callable[[], float] = time.monotonic,
                 t0: float | None = None) -> None:
        self.stream = stream if stream is not None else sys.stdout
        self.tty = _isatty(self.stream) if tty is None else tty
        self.total, self.initial = total, initial
        self.done, self.failed, self.in_flight = initial, initial_failed, 0
        self.clock = clock
        self.t0 = clock() if t0 is None else t0      # the sweep's start, on the same clock
        self._bar = self._open_bar() if self.tty else None

    # -- what is shown

    def elapsed(self) -> float:
        return self.clock() - self.t0

    def eta(self) -> str:
        now = self.done - self.initial
        if self.done >= self.total:
            return fmt_s(0)
        return fmt_s(self.elapsed() / now * (self.total - self.done)) if now > 0 else "?"

    def status(self) -> str:
        """The bar's text after the bar itself."""
        return (f"{self.failed} failed, {self.in_flight} in flight, elapsed {fmt_s(self.elapsed())}, "
                f"ETA {self.eta()}")

    # -- events

    def run_done(self, label: str, row: dict[str, Any]) -> None:
        """A run finished (passed or failed): its line, then the counts."""
        self.done += 1
        self.failed += not row.get("pass")
        self.in_flight = max(0, self.in_flight - 1)
        if self._bar is None:
            self._plain(f"[sweep] {self.done}/{self.total} done, {self.failed} failed, elapsed "
                        f"{fmt_s(self.elapsed())}, ETA {self.eta()} | {label}: {result_text(row)}")
        else:
            self.write(f"[sweep] {self.done}/{self.total} {label}: {result_text(row)}")

    def running(self, n: int) -> None:
        """n runs are in flight now; on a terminal the bar is redrawn (its elapsed time moves on)."""
        self.in_flight = n
        self._redraw()

    def write(self, text: str) -> None:
        """A line of text; on a terminal above the bar, which is drawn again under it."""
        if self._bar is None:
            self._plain(text)
        else:
            self._bar.write(text, file=self.stream)
            self._redraw()

    def close(self) -> None:
        """The final state stays on screen; the cursor is left on a fresh line. Idempotent."""
        if self._bar is not None:
            bar, self._bar = self._bar, None
            self.in_flight = 0 if self.done >= self.total else self.in_flight
            bar.status, bar.n = self.status(), self.done
            bar.close()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- drawing

    def _plain(self, text: str) -> None:
        self.stream.write(text + "\n")
        self.stream.flush()

    def _redraw(self) -> None:
        if self._bar is not None:
            self._bar.status, self._bar.n = self.status(), self.done
            self._bar.refresh()

    def _open_bar(self):
        from tqdm import tqdm

        class Bar(tqdm):
            """tqdm with our status text in its bar_format; no monitor thread (we redraw on events
            and on each wait of the sweep loop, about once a second)."""
            monitor_interval = 0
            status = ""

            @property
            def format_dict(self):
                return {**super().format_dict, "status": self.status}

        bar = Bar(total=self.total, initial=self.initial, file=self.stream, dynamic_ncols=True, mininterval=0,
                  leave=True, bar_format="[sweep] {n}/{total} |{bar}| {status}")
        bar.status = self.status()
        bar.refresh()
        return bar


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):     # no isatty, or a closed file
        return False
