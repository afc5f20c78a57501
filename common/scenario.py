"""Scenario files: static frames, the tower's goals and the follow settings.

A scenario is TOML (see common/scenarios/default.toml). Its static frames are
written exactly like static_transform_publisher arguments, and this module holds
the one parser for that form, used by the loader and by
`towerlink static-transform`.

Vehicles. The lab has one drone (frame ``drone``, sysid 1) and its rover (``rover``,
sysid 2). A scenario may instead list a family (common/scenarios/family.toml)::

    [[drones]]                 # one table per drone, in sysid order (1, 2, ...)
    name = "drone1"            # its frame id (and drone1_yaw)
    altitude = 8.0             # its own altitude layer, m above home
    rover = "rover1"           # the rover that follows it (omit: none)
    goals = [[x, y], ...]      # its own queue of goals, in mission.goal_frame

and mount the tower on a van (common/scenarios/van.toml): ``[van]`` names a rover that
drives a route of its own (world NED [x, y], looped) and the tower is a static child
of the van frame, so world -> tower changes as the van drives and turns.

Sysids follow `towerlink sitl --drones N --rovers M`: drones first (1..N), then the
following rovers in their drones' order, then the van. Separation (see
:func:`check_separation`): two drones fly altitude layers at least
``mission.min_separation`` m apart, or paths (start and goals, world) that far apart in the
horizontal (common/family_plan.py generates 100 drones in lanes on two layers).

Faults. ``[[faults]]`` tables give a fault timeline: at sim time t, parameters set on a vehicle
(ArduPilot SITL's SIM_* faults) or the tower link made lossy, slow, jittery, narrow
(common/scenario_faults.py; `towerlink fly` applies them, tools/fault_timeline.py).
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

from common.frames import (Buffer, InvalidArgumentException, Transform,
                           TransformStamped)
from common.scenario_faults import Fault, parse_faults

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
class DroneSpec:
    """One drone of the scenario and the rover that follows it (if any)."""
    name: str                                        # frame id, e.g. "drone1"
    sysid: int
    altitude: float                                  # m above home: its layer
    goals: tuple[tuple[float, float, float], ...]    # in the scenario's goal_frame, z down
    rover: str | None = None                         # frame id of its follower
    rover_sysid: int | None = None


@dataclass(frozen=True)
class VanSpec:
    """A rover that carries the tower and drives its own route (world NED, m)."""
    name: str
    sysid: int
    route: tuple[tuple[float, float], ...]           # world [x, y], driven in order, looped
    speed: float                                     # m/s (the rover's WP_SPEED)


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
    drones: tuple[DroneSpec, ...] = ()
    van: VanSpec | None = None
    min_separation: float = 3.0                      # m between drone altitude layers

    @property
    def rovers(self) -> list[tuple[str, int]]:
        """(name, sysid) of every rover in sysid order: followers, then the van."""
        out = [(d.rover, d.rover_sysid) for d in self.drones if d.rover]
        if self.van is not None:
            out.append((self.van.name, self.van.sysid))
        return out

    @property
    def vehicles(self) -> list[tuple[str, int, str]]:
        """(name, sysid, kind) of every vehicle, kind "copter" or "rover", in sysid order."""
        return [(d.name, d.sysid, "copter") for d in self.drones] + \
            [(n, s, "rover") for n, s in self.rovers]

    @property
    def pairs(self) -> list[tuple[int, int]]:
        """(drone sysid, rover sysid) for every drone that a rover follows."""
        return [(d.sysid, d.rover_sysid) for d in self.drones if d.rover_sysid is not None]

    @property
    def is_family(self) -> bool:
        """More than the lab's one drone and one rover (names, sysids or a van)."""
        return [(n, s) for n, s, _k in self.vehicles] != [("drone", 1), ("rover", 2)]
    wind: tuple[float, float, float] | None = None   # speed m/s, from-direction deg, turbulence m/s
    faults: tuple[Fault, ...] = ()                   # the fault timeline (common/scenario_faults.py)

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


def shipped_scenarios() -> list[str]:
    """Names of the scenarios shipped in common/scenarios (``towerlink fly NAME``)."""
    return sorted(p.stem for p in DEFAULT_SCENARIO.parent.glob("*.toml"))


def scenario_path(path: str | Path | None) -> Path:
    """A file path, or the name of a shipped scenario ("family", "van"); None: the default."""
    if path is None:
        return DEFAULT_SCENARIO
    p = Path(path)
    if not p.exists() and p.suffix == "" and p.parent == Path("."):
        shipped = DEFAULT_SCENARIO.parent / f"{p.name}.toml"
        if shipped.exists():
            return shipped
    return p


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Load and validate a scenario file or a shipped one by name (the default when None)."""
    path = scenario_path(path)
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file (shipped: {', '.join(shipped_scenarios())})") from None
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

    min_sep = _number(mission.get("min_separation", 3.0), "mission.min_separation", fail)
    drones, van = _vehicles(data, goals, altitude, fail)
    owned = {d.name for d in drones} | {d.rover for d in drones if d.rover} | \
        ({van.name} if van else set())
    for ts in statics:
        if ts.child_frame_id in owned:
            raise fail(f"static_transforms: {ts.child_frame_id!r} is a vehicle's frame; "
                       f"it cannot also be static")
    if van is not None and van.name not in {ts.frame_id for ts in statics}:
        raise fail(f"van {van.name!r}: no static transform hangs a frame on it "
                   f"(e.g. \"0 0 0 0 0 0 {van.name} tower\")")
    sc = Scenario(
        name=str(data.get("name", path.stem)), path=path, wind=wind,
        static_transforms=tuple(statics), goals=tuple(goals), goal_frame=goal_frame,
        altitude=altitude, radius=radius, finish=finish, follow_frame=follow_frame,
        follow_offset=(_number(offset[0], "follow.offset", fail), _number(offset[1], "follow.offset", fail)),
        follow_rate_hz=rate, drones=drones, van=van, min_separation=min_sep,
    )
    sc = replace(sc, faults=parse_faults(data.get("faults"), sc.vehicles, fail))
    problem = check_separation(sc)
    if problem:
        raise fail(problem)
    return sc


def check_separation(sc: Scenario) -> str | None:
    """Why two drones of the plan could come closer than min_separation (None if they cannot).

    Each drone flies its whole queue at its own altitude layer, from where the world boots
    it (common.family_plan.drone_start) through its goals. Two drones whose layers are at least
    min_separation apart never meet; two closer layers (the same one, say) are allowed only
    when their paths keep min_separation apart in the horizontal (world frame, the goals
    resolved through the scenario's static frames). A goal frame on a moving vehicle (the
    van) cannot be resolved ahead of time: there every drone needs its own layer.
    """
    ds = list(sc.drones)
    paths = _world_paths(sc)
    for a in range(len(ds)):
        for b in range(a + 1, len(ds)):
            da, db = ds[a], ds[b]
            if abs(da.altitude - db.altitude) >= sc.min_separation - 1e-9:
                continue
            if paths is None:
                lo, hi = sorted((da, db), key=lambda d: d.altitude)
                return (f"drones {lo.name!r} ({lo.altitude:g} m) and {hi.name!r} ({hi.altitude:g} m) fly layers "
                        f"{hi.altitude - lo.altitude:g} m apart; mission.min_separation is {sc.min_separation:g} m")
            gap = _path_gap(paths[a], paths[b], sc.min_separation)
            if gap < sc.min_separation - 1e-9:
                return (f"drones {da.name!r} ({da.altitude:g} m) and {db.name!r} ({db.altitude:g} m) fly layers "
                        f"{abs(da.altitude - db.altitude):g} m apart and their paths come {gap:.2f} m close "
                        f"in the horizontal; mission.min_separation is {sc.min_separation:g} m")
    return None


def _world_paths(sc: Scenario) -> list[list[tuple[float, float]]] | None:
    """Each drone's horizontal path in world (start, then its goals), or None if the goal
    frame does not hang on world by static frames."""
    from common.family_plan import drone_start
    from common.frames import TransformException
    if len(sc.drones) < 2:
        return []
    try:
        T = sc.buffer().lookup_transform("world", sc.goal_frame).transform
    except TransformException:
        return None
    return [[drone_start(k)] + [tuple(float(v) for v in T.apply_point(g)[:2]) for g in d.goals]
            for k, d in enumerate(sc.drones)]


def _path_gap(pa: list[tuple[float, float]], pb: list[tuple[float, float]], enough: float) -> float:
    """Smallest horizontal distance between two polylines (m); stops early once below `enough`
    is impossible to exceed (bounding boxes farther apart than `enough` answer at once)."""
    def box(p):
        xs, ys = [q[0] for q in p], [q[1] for q in p]
        return min(xs), max(xs), min(ys), max(ys)
    ax0, ax1, ay0, ay1 = box(pa)
    bx0, bx1, by0, by1 = box(pb)
    far = max(bx0 - ax1, ax0 - bx1, by0 - ay1, ay0 - by1, 0.0)
    if far >= enough:
        return far
    sa = list(zip(pa, pa[1:])) or [(pa[0], pa[0])]
    sb = list(zip(pb, pb[1:])) or [(pb[0], pb[0])]
    return min(_segment_gap(p, q, r, s) for p, q in sa for r, s in sb)


def _segment_gap(p, q, r, s) -> float:
    """Distance between segments pq and rs in the plane (0 when they cross)."""
    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    d1, d2, d3, d4 = cross(r, s, p), cross(r, s, q), cross(p, q, r), cross(p, q, s)
    if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and 0 not in (d1, d2, d3, d4):
        return 0.0
    return min(_point_segment(p, r, s), _point_segment(q, r, s), _point_segment(r, p, q), _point_segment(s, p, q))


def _point_segment(p, a, b) -> float:
    ax, ay = b[0] - a[0], b[1] - a[1]
    L = ax * ax + ay * ay
    t = 0.0 if L == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * ax + (p[1] - a[1]) * ay) / L))
    return math.hypot(p[0] - a[0] - t * ax, p[1] - a[1] - t * ay)


def _vehicles(data: dict[str, Any], goals: list, altitude: float, fail) -> tuple[tuple[DroneSpec, ...], VanSpec | None]:
    """The drones (with their rovers) and the van; the lab's pair when none are listed."""
    tables = data.get("drones")
    if tables is None:
        specs = [dict(name="drone", altitude=altitude, goals=goals, rover="rover")]
    else:
        if not isinstance(tables, list) or not tables or not all(isinstance(t, dict) for t in tables):
            raise fail("drones must be a list of [[drones]] tables")
        specs = []
        for k, t in enumerate(tables):
            alt = _number(t.get("altitude", altitude), f"drones[{k}].altitude", fail)
            if not 0.5 <= alt <= 500.0:
                raise fail(f"drones[{k}].altitude {alt} m is outside 0.5..500 m")
            gl = []
            for i, g in enumerate(t.get("goals", [])):
                if not isinstance(g, list) or len(g) not in (2, 3):
                    raise fail(f"drones[{k}].goals[{i}] must be [x, y] or [x, y, z], got {g!r}")
                xyz = [_number(v, f"drones[{k}].goals[{i}]", fail) for v in g]
                gl.append((xyz[0], xyz[1], xyz[2] if len(xyz) == 3 else -alt))
            rover = t.get("rover")
            if rover is not None and not isinstance(rover, str):
                raise fail(f"drones[{k}].rover must be a frame name, got {rover!r}")
            specs.append(dict(name=str(t.get("name", f"drone{k + 1}")), altitude=alt, goals=gl, rover=rover))
    n = len(specs)
    drones, rover_sysid = [], n + 1
    for k, sp in enumerate(specs):
        rs = None
        if sp["rover"]:
            rs, rover_sysid = rover_sysid, rover_sysid + 1
        drones.append(DroneSpec(sp["name"], k + 1, sp["altitude"], tuple(sp["goals"]), sp["rover"], rs))
    van = None
    vt = data.get("van")
    if vt is not None:
        if not isinstance(vt, dict):
            raise fail("van must be a [van] table")
        route = []
        for i, p in enumerate(vt.get("route", [])):
            if not isinstance(p, list) or len(p) != 2:
                raise fail(f"van.route[{i}] must be [x, y] (world NED, m), got {p!r}")
            route.append(tuple(_number(v, f"van.route[{i}]", fail) for v in p))
        if len(route) < 2:
            raise fail("van.route needs at least two points")
        speed = _number(vt.get("speed", 2.0), "van.speed", fail)
        if not 0.1 <= speed <= 10.0:
            raise fail(f"van.speed {speed} m/s is outside 0.1..10 m/s")
        van = VanSpec(str(vt.get("name", "van")), rover_sysid, tuple(route), speed)
    names = [d.name for d in drones] + [d.rover for d in drones if d.rover] + ([van.name] if van else [])
    dup = {x for x in names if names.count(x) > 1}
    if dup:
        raise fail(f"vehicle names must differ: {sorted(dup)} used twice")
    return tuple(drones), van


def _number(value: Any, where: str, fail) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise fail(f"{where} must be a finite number, got {value!r}")
    return float(value)
