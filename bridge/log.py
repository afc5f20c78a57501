"""The bridge's log lines: stamped with wall seconds since it started, to stderr or to a sink."""
from __future__ import annotations

import sys
from collections.abc import Callable


class BridgeLog:
    """``log(text)`` writes a line; ``warn_once(key, text, period)`` writes it at most once
    every `period` wall seconds per key (a condition that persists, e.g. a missing transform,
    would otherwise write a line per packet)."""

    def __init__(self, clock: Callable[[], float], t0: float, sink: Callable[[str], None] | None = None,
                 quiet: bool = False) -> None:
        self.clock = clock              # () -> wall s
        self.t0 = t0                    # the bridge's start, wall s
        self._sink = sink               # a line -> None (tests keep them); None: stderr
        self.quiet = quiet
        self._warned: dict[str, float] = {}

    def log(self, text: str) -> None:
        if self._sink is not None:
            self._sink(text)
        elif not self.quiet:
            print(f"[bridge {self.clock() - self.t0:8.3f}] {text}", file=sys.stderr, flush=True)

    def warn_once(self, key: str, text: str, period: float = 2.0) -> bool:
        """Log `text` unless `key` was logged less than `period` wall s ago; True if logged."""
        now = self.clock()
        if now - self._warned.get(key, -1e9) >= period:
            self._warned[key] = now
            self.log(text)
            return True
        return False
