"""Scenario files: static frames, the tower's goals and the follow settings.

A scenario is TOML (see gcs/scenarios/default.toml). Its static frames are
written exactly like static_transform_publisher arguments, and this module holds
the one parser for that form, used by the loader and by
`towerlink static-transform`.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from gcs.frames import (Buffer, InvalidArgumentException, Transform,
                           TransformStamped)

DEFAULT_SCENARIO = Path(__file__).with_name("scenarios") / "default.toml"
SCENARIO_AUTHORITY = "scenario"
FOLLOW_FRAMES = ("drone", "drone_yaw")
FINISH_ACTIONS = ("land", "rtl")

STATIC_TRANSFORM_USAGE = ("x y z yaw pitch roll frame_id child_frame_id  |  "
                          "x y z qx qy qz qw frame_id child_frame_id")


class ScenarioError(ValueError):
    """A scenario file, or a static transform line, that cannot be used; says where and why."""


def parse_static_transform(args: Sequence[str] | str) -> TransformStamped:
    """Parse static_transform_publisher arguments into a TransformStamped (stamp 0).

    Eight values mean x y z yaw pitch roll parent child (radians,
    R = Rz(yaw) Ry(pitch) Rx(roll)); nine mean x y z qx qy qz qw parent child.
    Raises ScenarioError for the wrong count or non-numbers, and
    InvalidArgumentException (from the frame library) for non-finite values, a
    bad quaternion or bad frame ids.
    """
    tokens = args.split() if isinstance(args, str) else list(args)
    if len(tokens) not in (8, 9):
        raise ScenarioError(
            f"a static transform takes 8 or 9 arguments ({STATIC_TRANSFORM_USAGE}); got {len(tokens)}")
    *numbers, parent, child = tokens
    try:
        values = [float(v) for v in numbers]
    except ValueError as exc:
        raise ScenarioError(f"static transform values must be numbers: {exc}") from None
    xyz = values[:3]
    if len(values) == 6:
        yaw, pitch, roll = values[3:]
        transform = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll, translation=xyz)
    else:
        transform = Transform(translation=xyz, rotation=values[3:])
    return TransformStamped(frame_id=parent, child_frame_id=child, stamp=0.0, transform=transform)


@dataclass(frozen=True)
class Scenario:
    """Everything the world, bridge and tower need to fly one lab run."""

    name: str
    path: Path
    static_transforms: tuple[TransformStamped, ...]
    goals: tuple[tuple[float, float, float], ...]   # in goal_frame, z down
    goal_frame: str
    altitude: float                                  # m above home
    radius: float                                    # m
    finish: str                                      # land | rtl
    follow_frame: str                                # drone | drone_yaw
    follow_offset: tuple[float, float]               # m, in the yaw-only drone frame
    follow_rate_hz: float
    wind: tuple[float, float, float] | None = None   # speed m/s, from-direction deg, turbulence m/s

    def wind_arg(self) -> str | None:
        """The wind as `towerlink sitl --wind` takes it (SPD,DIR,TURB), or None when calm/unset."""
        return None if self.wind is None else ",".join(f"{v:g}" for v in self.wind)

    def buffer(self, cache_time: float = 10.0) -> Buffer:
        """A frame Buffer holding this scenario's static frames."""
        buf = Buffer(cache_time=cache_time)
        for ts in self.static_transforms:
            buf.set_transform_static(ts, SCENARIO_AUTHORITY)
        return buf

    def frames(self) -> list[str]:
        """Every frame id the scenario names, parents first."""
        seen: dict[str, None] = {}
        for ts in self.static_transforms:
            seen.setdefault(ts.frame_id)
            seen.setdefault(ts.child_frame_id)
        return list(seen)


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Load and validate a scenario file (the built-in default when path is None)."""
    path = Path(path) if path is not None else DEFAULT_SCENARIO
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    return _build(data, path)


def _build(data: dict[str, Any], path: Path) -> Scenario:
    def fail(msg: str) -> ScenarioError:
        return ScenarioError(f"{path}: {msg}")

    statics = []
    for k, line in enumerate(data.get("static_transforms", [])):
        if not isinstance(line, str):
            raise fail(f"static_transforms[{k}] must be a string like {STATIC_TRANSFORM_USAGE!r}")
        try:
            statics.append(parse_static_transform(line))
        except (ScenarioError, InvalidArgumentException) as exc:
            raise fail(f"static_transforms[{k}] {line!r}: {exc}") from None
    # A buffer refuses loops and bad ids; building one validates the tree.
    try:
        buf = Buffer()
        for ts in statics:
            buf.set_transform_static(ts, SCENARIO_AUTHORITY)
    except InvalidArgumentException as exc:
        raise fail(f"static_transforms: {exc}") from None

    mission = data.get("mission", {})
    altitude = _number(mission.get("altitude", 9.0), "mission.altitude", fail)
    if not 0.5 <= altitude <= 500.0:
        raise fail(f"mission.altitude {altitude} m is outside 0.5..500 m")
    radius = _number(mission.get("radius", 0.5), "mission.radius", fail)
    if not 0.05 <= radius <= 50.0:
        raise fail(f"mission.radius {radius} m is outside 0.05..50 m")
    goal_frame = str(mission.get("goal_frame", "tower"))
    known = {ts.frame_id for ts in statics} | {ts.child_frame_id for ts in statics} | {"world"}
    if goal_frame not in known:
        raise fail(f"mission.goal_frame {goal_frame!r} is not a frame of this scenario ({sorted(known)})")
    goals = []
    for k, g in enumerate(mission.get("goals", [])):
        if not isinstance(g, list) or len(g) not in (2, 3):
            raise fail(f"mission.goals[{k}] must be [x, y] or [x, y, z], got {g!r}")
        xyz = [_number(v, f"mission.goals[{k}]", fail) for v in g]
        goals.append((xyz[0], xyz[1], xyz[2] if len(xyz) == 3 else -altitude))
    finish = str(mission.get("finish", "land"))
    if finish not in FINISH_ACTIONS:
        raise fail(f"mission.finish {finish!r} must be one of {FINISH_ACTIONS}")

    follow = data.get("follow", {})
    follow_frame = str(follow.get("frame", "drone_yaw"))
    if follow_frame not in FOLLOW_FRAMES:
        raise fail(f"follow.frame {follow_frame!r} must be one of {FOLLOW_FRAMES}")
    offset = follow.get("offset", [0.0, 0.0])
    if not isinstance(offset, list) or len(offset) != 2:
        raise fail(f"follow.offset must be [x, y], got {offset!r}")
    rate = _number(follow.get("rate_hz", 10.0), "follow.rate_hz", fail)
    if not 1.0 <= rate <= 100.0:
        raise fail(f"follow.rate_hz {rate} is outside 1..100 Hz")

    wind = None
    if "wind" in data:
        w = data["wind"]
        if not isinstance(w, dict) or set(w) - {"speed", "direction", "turbulence"} or "speed" not in w:
            raise fail("wind must be a table like {speed = 8, direction = 270, turbulence = 1} "
                       f"(speed m/s, direction it comes from in degrees, turbulence m/s), got {w!r}")
        speed = _number(w["speed"], "wind.speed", fail)
        direction = _number(w.get("direction", 180.0), "wind.direction", fail)
        turb = _number(w.get("turbulence", 0.0), "wind.turbulence", fail)
        if not 0.0 <= speed <= 40.0:
            raise fail(f"wind.speed {speed:g} m/s is outside 0..40 (SIM_WIND_SPD)")
        if not 0.0 <= direction <= 360.0:
            raise fail(f"wind.direction {direction:g} deg is outside 0..360 (where the wind comes from)")
        if not 0.0 <= turb <= 10.0:
            raise fail(f"wind.turbulence {turb:g} m/s is outside 0..10 (SIM_WIND_TURB)")
        wind = (speed, direction, turb)

    return Scenario(
        name=str(data.get("name", path.stem)), path=path, wind=wind,
        static_transforms=tuple(statics), goals=tuple(goals), goal_frame=goal_frame,
        altitude=altitude, radius=radius, finish=finish, follow_frame=follow_frame,
        follow_offset=(_number(offset[0], "follow.offset", fail), _number(offset[1], "follow.offset", fail)),
        follow_rate_hz=rate,
    )


def _number(value: Any, where: str, fail) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise fail(f"{where} must be a finite number, got {value!r}")
    return float(value)
