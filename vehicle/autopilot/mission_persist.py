"""A MissionStore that survives restarts: saved beside the vehicle's parameter file
(STATE_DIR/drone0.parm -> STATE_DIR/drone0.missions.json), as ArduPilot keeps missions,
fence and rally points in its storage next to the parameters.

Every change is written atomically (a temporary file, then os.replace), so a crash leaves
the old file or the new one, never half of one. A file that cannot be read back (bad JSON,
wrong shape, bad values) is renamed to FILE.bad with a warning, and the vehicle starts with
empty lists.
"""
from __future__ import annotations

import json
import os
import warnings
from collections.abc import Callable
from dataclasses import astuple, fields

from vehicle.autopilot.mission_store import MISSION_TYPES, MissionItem, MissionStore

FORMAT = "towerlink-missions"
VERSION = 1
_FIELDS = [f.name for f in fields(MissionItem)]
_INTS = {"seq", "frame", "command", "current", "autocontinue", "x", "y", "mission_type"}


def missions_path(parm_path: str) -> str:
    """The missions file beside a vehicle's parameter file."""
    base = parm_path[:-5] if parm_path.endswith(".parm") else parm_path
    return base + ".missions.json"


def _item(row, t: int) -> MissionItem:
    if not isinstance(row, list) or len(row) != len(_FIELDS):
        raise ValueError("item is not a list of %d fields" % len(_FIELDS))
    kw = {}
    for name, v in zip(_FIELDS, row):
        if name in _INTS:
            if not isinstance(v, int) or isinstance(v, bool):
                raise ValueError(f"{name} is not an integer")
            kw[name] = v
        else:
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                raise ValueError(f"{name} is not a number")
            kw[name] = float(v)
    if kw["mission_type"] != t:
        raise ValueError("item of another list")
    return MissionItem(**kw)


def load(path: str) -> dict[int, list[MissionItem]]:
    """The lists in `path`; raises ValueError (or OSError) when the file is damaged."""
    with open(path) as f:
        data = json.load(f)
    if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("version") != VERSION:
        raise ValueError("not a towerlink missions file (format/version)")
    lists = data.get("lists")
    if not isinstance(lists, dict):
        raise ValueError("no lists")
    out = {}
    for t in MISSION_TYPES:
        rows = lists.get(str(t), [])
        if not isinstance(rows, list):
            raise ValueError(f"list {t} is not a list")
        items = [_item(r, t) for r in rows]
        if [it.seq for it in items] != list(range(len(items))):
            raise ValueError(f"list {t}: seqs are not 0..n-1")
        out[t] = items
    return out


def save(path: str, lists: dict[int, list[MissionItem]]) -> None:
    """Write atomically: tmp file in the same directory, fsync, os.replace."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    data = {"format": FORMAT, "version": VERSION,
            "lists": {str(t): [list(astuple(it)) for it in lists[t]] for t in MISSION_TYPES}}
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        json.dump(data, f)        # NaN (an allowed waypoint yaw) is written as NaN, read back by json
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


class PersistentMissionStore(MissionStore):
    """MissionStore loaded from and saved to `path` on every change."""

    def __init__(self, path: str, on_change: Callable[[int], None] | None = None) -> None:
        super().__init__(on_change)
        self.path = path
        self.load_error: str | None = None
        if os.path.exists(path):
            try:
                self.lists.update(load(path))
            except (OSError, ValueError, TypeError) as e:        # json.JSONDecodeError is a ValueError
                self.load_error = f"{e}"
                bad = path + ".bad"
                try:
                    os.replace(path, bad)
                except OSError:
                    bad = "(could not be renamed)"
                warnings.warn(f"towerlink: damaged missions file {path} set aside as {bad}: {e}; "
                              "starting with no mission, fence or rally points", RuntimeWarning, stacklevel=2)

    def _changed(self, mission_type: int) -> None:
        save(self.path, self.lists)
        super()._changed(mission_type)
