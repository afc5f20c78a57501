"""Shared helper of the in-process fleet tests (control, estimation): step a fleet."""
from __future__ import annotations

from collections.abc import Callable

DT = 1.0 / 400.0      # the design step, s


def run(f, secs: float, cb: Callable | None = None, dt: float = DT) -> None:
    """Step fleet f for `secs` sim seconds at dt, calling cb(f) after every step."""
    for _ in range(round(secs / dt)):
        f.step(dt)
        if cb is not None:
            cb(f)
