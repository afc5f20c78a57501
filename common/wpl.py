"""QGC WPL 110 waypoint files: what QGroundControl, Mission Planner and MAVProxy write.

    QGC WPL 110
    0	1	0	16	0	0	0	0	-35.363261	149.165230	584.000000	1
    1	0	3	22	0	0	0	0	0.000000	0.000000	20.000000	1

One item a line, tab (or space) separated: INDEX CURRENT FRAME COMMAND PARAM1 PARAM2 PARAM3
PARAM4 X/LAT Y/LON Z/ALT AUTOCONTINUE; lat/lon in degrees, alt in metres in FRAME's sense.
Line 0 is home by convention (ArduPilot ignores the uploaded one). Blank lines and lines
starting with # are skipped. A malformed file raises WplError naming the file and line.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

HEADER = "QGC WPL 110"


class WplError(ValueError):
    """A waypoint file that cannot be read; the message names FILE:LINE."""


@dataclass(frozen=True)
class WplItem:
    """One line: x / y are degrees (or raw values for commands that do not carry a location)."""
    seq: int
    current: int
    frame: int
    command: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: float
    y: float
    z: float
    autocontinue: int = 1


def parse(text: str, name: str = "<text>") -> list[WplItem]:
    lines = text.splitlines()
    if not lines or lines[0].strip() != HEADER:
        raise WplError(f"{name}:1: not a waypoint file (first line must be '{HEADER}')")
    items: list[WplItem] = []
    for n, raw in enumerate(lines[1:], start=2):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        f = line.split()
        if len(f) != 12:
            raise WplError(f"{name}:{n}: expected 12 fields, got {len(f)}")
        try:
            ints = [int(f[i]) for i in (0, 1, 2, 3, 11)]
            floats = [float(v) for v in f[4:11]]
        except ValueError as e:
            raise WplError(f"{name}:{n}: {e}") from None
        seq, current, frame, command, autocontinue = ints
        if seq != len(items):
            raise WplError(f"{name}:{n}: index {seq}, expected {len(items)}")
        if not all(0 <= v <= 0xFFFF for v in (frame, command)) or current not in (0, 1) \
                or autocontinue not in (0, 1):
            raise WplError(f"{name}:{n}: frame/command/current/autocontinue out of range")
        if not all(math.isfinite(v) for v in floats[4:]):
            raise WplError(f"{name}:{n}: x/y/z must be finite")
        items.append(WplItem(seq, current, frame, command, *floats, autocontinue=autocontinue))
    return items


def read(path: str) -> list[WplItem]:
    """Items of the file at `path` (WplError if malformed, OSError if unreadable)."""
    with open(path) as f:
        return parse(f.read(), path)


def format_items(items: list[WplItem]) -> str:
    out = [HEADER]
    for i, it in enumerate(items):
        out.append("\t".join([str(i), str(it.current), str(it.frame), str(it.command)]
                             + [f"{v:.8f}" for v in (it.param1, it.param2, it.param3, it.param4, it.x, it.y)]
                             + [f"{it.z:.6f}", str(it.autocontinue)]))
    return "\n".join(out) + "\n"


def write(path: str, items: list[WplItem]) -> None:
    """Write atomically (tmp + os.replace)."""
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        f.write(format_items(items))
    os.replace(tmp, path)
