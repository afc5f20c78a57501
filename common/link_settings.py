"""One direction of a faulty radio link: what it loses, delays, reorders, doubles, and how fast it is (pure).

A link has two directions: ``up`` (from the ground station towards the vehicles: the tower's
goals and heartbeats) and ``down`` (back: telemetry, the bridge's transform stream). Each is a
:class:`LinkSettings`; all zero is a perfect link. Times are seconds on the clock the link runs
on (sim seconds in lockstep, wall seconds without), sizes bytes:

  loss       0..1     fraction of MAVLink frames lost
  latency    0..60 s  one-way delay of every frame
  jitter     0..60 s  extra delay, uniform in [0, jitter] per frame (frames may overtake)
  reorder    0..1     fraction of frames held back REORDER_HOLD s more, so later ones overtake
  duplicate  0..1     fraction of frames delivered twice
  bandwidth  bytes/s  the link's capacity, 0 = unlimited; frames wait their turn, and a frame
                      that would wait more than QUEUE_LIMIT s is dropped (the radio's queue is full)

The written form (``towerlink fly --tower-link``, a sweep's ``tower_link.*`` factors):
``loss=0.1,latency=0.2,up.bandwidth=2000`` (a bare name sets both directions, ``up.`` or
``down.`` one). The link model itself is tools/link_shaper.py.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any, Mapping

DIRECTIONS = ("up", "down")
REORDER_HOLD = 0.1          # s a reordered frame is held back beyond its delay
QUEUE_LIMIT = 1.0           # s of backlog a capped link queues before it drops (tail drop)

#: name -> (lowest, highest, what it means)
SETTINGS = {
    "loss": (0.0, 1.0, "fraction of frames lost"),
    "latency": (0.0, 60.0, "one-way delay, s"),
    "jitter": (0.0, 60.0, "extra delay uniform in [0, jitter], s"),
    "reorder": (0.0, 1.0, f"fraction of frames held back {REORDER_HOLD:g} s more"),
    "duplicate": (0.0, 1.0, "fraction of frames delivered twice"),
    "bandwidth": (0.0, 1e9, "capacity in bytes/s, 0 = unlimited"),
}


@dataclass(frozen=True)
class LinkSettings:
    """One direction's faults (see the module doc); all zero: a perfect link."""
    loss: float = 0.0
    latency: float = 0.0
    jitter: float = 0.0
    reorder: float = 0.0
    duplicate: float = 0.0
    bandwidth: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            check_setting(f.name, getattr(self, f.name))

    @property
    def active(self) -> bool:
        """Does this direction do anything to the frames?"""
        return any(getattr(self, f.name) for f in fields(self))

    def changed(self, changes: Mapping[str, float]) -> "LinkSettings":
        """A copy with some settings replaced (names checked)."""
        return replace(self, **{k: check_setting(k, v) for k, v in changes.items()})

    def as_dict(self) -> dict[str, float]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def describe(self) -> str:
        """'loss=0.2 latency=0.3', the settings that are not zero ('perfect' when none)."""
        return describe_changes({k: v for k, v in self.as_dict().items() if v}) or "perfect"


def check_setting(name: str, value: Any) -> float:
    """`value` as a float if it is a valid `name` setting; ValueError saying why not."""
    if name not in SETTINGS:
        raise ValueError(f"unknown link setting {name!r} (known: {', '.join(SETTINGS)})")
    lo, hi, what = SETTINGS[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"link setting {name} must be a finite number ({what}), got {value!r}")
    if not lo <= value <= hi:
        raise ValueError(f"link setting {name} {value:g} is outside {lo:g}..{hi:g} ({what})")
    return float(value)


def describe_changes(changes: Mapping[str, float]) -> str:
    """'loss=1 up.latency=0.2' for {"loss": 1.0, "up.latency": 0.2}."""
    return " ".join(f"{k}={v:g}" for k, v in changes.items())


def split_key(key: str) -> tuple[tuple[str, ...], str]:
    """'latency' -> (("up", "down"), "latency"); 'up.loss' -> (("up",), "loss"); ValueError if neither."""
    where, dot, name = key.rpartition(".")
    if not dot:
        directions: tuple[str, ...] = DIRECTIONS
    elif where in DIRECTIONS:
        directions = (where,)
    else:
        raise ValueError(f"link setting {key!r}: write NAME, up.NAME or down.NAME (NAME one of {', '.join(SETTINGS)})")
    if name not in SETTINGS:
        raise ValueError(f"unknown link setting {key!r} (known: {', '.join(SETTINGS)}, each also as up.NAME or down.NAME)")
    return directions, name


def per_direction(changes: Mapping[str, float]) -> dict[str, dict[str, float]]:
    """{"loss": 0.1, "up.latency": 0.2} -> {"up": {"loss": 0.1, "latency": 0.2}, "down": {"loss": 0.1}},
    every value checked (ValueError); a direction's own key wins over a bare one."""
    out: dict[str, dict[str, float]] = {d: {} for d in DIRECTIONS}
    for key in sorted(changes, key=lambda k: "." in k):         # bare names first, then up./down.
        directions, name = split_key(key)
        value = check_setting(name, changes[key])
        for d in directions:
            out[d][name] = value
    return out


def parse_link_spec(text: str) -> dict[str, float]:
    """'loss=0.1,up.latency=0.2' -> {"loss": 0.1, "up.latency": 0.2}, checked; ValueError if bad."""
    out: dict[str, float] = {}
    for item in (s.strip() for s in text.split(",")):
        if not item:
            continue
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise ValueError(f"{item!r}: write NAME=VALUE, e.g. loss=0.1 or up.latency=0.2")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"{item!r}: {value.strip()!r} is not a number") from None
        directions, name = split_key(key)
        check_setting(name, number)
        out[key] = number
    return out


def settings_pair(changes: Mapping[str, float], base: Mapping[str, LinkSettings] | None = None) -> dict[str, LinkSettings]:
    """{"up": LinkSettings, "down": LinkSettings} from written changes over `base` (default: perfect)."""
    base = base or {d: LinkSettings() for d in DIRECTIONS}
    return {d: base[d].changed(c) for d, c in per_direction(changes).items()}
