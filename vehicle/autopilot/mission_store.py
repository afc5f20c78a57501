"""A vehicle's stored missions, fence and rally points (pure: no sockets, no clocks).

The contract between the mission protocol (vehicle/link/, which fills and reads the store)
and the mission runner (vehicle/autopilot/, which flies what is stored):

- One list per MAV_MISSION_TYPE: MISSION (0), FENCE (1), RALLY (2). Items are kept exactly
  as they arrived (MISSION_ITEM_INT fields: frame, command, params, x/y as int, z), so a
  download returns what was uploaded.
- MISSION: seq 0 is home, as in ArduPilot (what an upload's item 0 does and what a
  download's item 0 says follow ArduPilot; the runner flies from seq 1).
- `version[t]` increments on every change of list t, so readers notice a new upload.
- `on_change(mission_type)` is called after every change (the autopilot reacts to an upload
  while flying; the world persists the store).

Persistence (atomic write, recovery from a damaged file) is added beside this by the
protocol side; this module only holds the data.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

MISSION, FENCE, RALLY = 0, 1, 2
MISSION_TYPES = (MISSION, FENCE, RALLY)


@dataclass(frozen=True)
class MissionItem:
    """One stored item, as MISSION_ITEM_INT carries it.

    x, y: latitude / longitude in degE7 for global frames; for local frames metres * 1e4
    (the MISSION_ITEM_INT convention). z: altitude in metres (frame says relative to what)
    or local z (NED down is negative up: MAVLink local frames keep their own sign).
    """
    seq: int
    frame: int
    command: int
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    mission_type: int = MISSION

    @property
    def params(self) -> tuple[float, float, float, float]:
        return (self.param1, self.param2, self.param3, self.param4)

    def with_seq(self, seq: int) -> "MissionItem":
        return replace(self, seq=seq)


class MissionStore:
    """The three lists of one vehicle. Index i of a list holds the item with seq i."""

    def __init__(self, on_change: Callable[[int], None] | None = None) -> None:
        self.lists: dict[int, list[MissionItem]] = {t: [] for t in MISSION_TYPES}
        self.version: dict[int, int] = {t: 0 for t in MISSION_TYPES}
        self.on_change = on_change or (lambda mission_type: None)

    def items(self, mission_type: int = MISSION) -> list[MissionItem]:
        return self.lists[mission_type]

    def count(self, mission_type: int = MISSION) -> int:
        return len(self.lists[mission_type])

    def get(self, seq: int, mission_type: int = MISSION) -> MissionItem | None:
        lst = self.lists[mission_type]
        return lst[seq] if 0 <= seq < len(lst) else None

    def replace_all(self, mission_type: int, items: list[MissionItem]) -> None:
        """A whole upload (or a clear, with []): seqs are renumbered 0..n-1."""
        self.lists[mission_type] = [it.with_seq(i) for i, it in enumerate(items)]
        self._changed(mission_type)

    def write_partial(self, mission_type: int, start: int, items: list[MissionItem]) -> None:
        """MISSION_WRITE_PARTIAL_LIST: replace items start..start+len-1 in place."""
        lst = self.lists[mission_type]
        for k, it in enumerate(items):
            lst[start + k] = it.with_seq(start + k)
        self._changed(mission_type)

    def clear(self, mission_type: int = MISSION) -> None:
        self.replace_all(mission_type, [])

    def _changed(self, mission_type: int) -> None:
        self.version[mission_type] += 1
        self.on_change(mission_type)
