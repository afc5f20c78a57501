"""What a run looks like in Foxglove: MAVLink messages in, Foxglove records out (pure).

One converter for both the live view (`towerlink fly --view`, tools/live_view.py) and the
recording (`run.mcap`, tools/run_mcap.py), so the two always carry the same channels:

  /tf        foxglove.FrameTransforms  every dynamic edge of the bridge's tree (TOWERLINK_TRANSFORM)
  /tf_static foxglove.FrameTransforms  its static edges (as ROS splits them; the bridge re-sends
                                       them, so a viewer that joins late still gets them)
  /vehicles  foxglove.SceneUpdate      each vehicle drawn in its own frame (drone, rover),
                                       so it moves and tilts exactly as the tree says, plus
                                       its track in `world`
  /goals     foxglove.SceneUpdate      the tower's goals as spheres in the `tower` frame
                                       (SET_POSITION_TARGET_LOCAL_NED from the tower, sysid 255)
  /follow    foxglove.SceneUpdate      the rover's target through the full-attitude frame
                                       (red) and the yaw-only frame (green), in `world`:
                                       the wobble is the distance between them
  /summary   towerlink.Summary         running figures: sim time, follow error RMS, wobble RMS

Display frame: the world is NED (z down) while Foxglove's 3D view is z up, so the feed adds
one static edge of its own, `world_enu -> world` (ENU to NED: x and y swapped, z flipped),
on /tf_static with the first record and again every 10 s. It is the only edge not from the
bridge; choose `world_enu` as the display frame and the drone flies above the ground.

Time: every record is stamped with sim time in nanoseconds. TOWERLINK_* messages carry
sim time themselves (time_usec); vehicle messages carry the vehicle's time_boot_ms, which
in towerlink is the world's sim clock; a message with neither (SIM_STATE) takes the latest
sim time seen from its sender. Messages are expected in arrival order, as a tlog holds them.

Encoding: JSON with Foxglove's schema names, so the Foxglove app recognises the types and
`mcap cat --json` (or any MCAP reader) shows them without a protobuf toolchain.
"""
from __future__ import annotations

import json
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from common.mavlink.ids import TOWER_SYSID
from common.mavlink.mavstr import mav_str

DISPLAY_FRAME = "world_enu"
ENU_TO_NED_Q = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)   # x, y, z, w: the NED axes seen in ENU
FRAME_COLORS = {"drone": (0.15, 0.45, 0.95, 1.0), "rover": (0.95, 0.55, 0.1, 1.0)}
TRACK_STEP_M = 0.25          # a track point every quarter metre: a 1 km flight is 4,000 points
SCENE_PERIOD_S = 0.1         # scene updates at 10 Hz of sim time (transforms go at full rate)
TRACK_SEGMENT = 200          # a track is sent in segments: only the growing one each update,
TRACK_RESEND_S = 10.0        # and all of them every 10 s, so a viewer that joins late sees it all
#: the messages whose fields SceneFeed reads; any other counts only through its sim time
#: (time_boot_ms, or a TOWERLINK_ message's time_usec), and one with neither makes no record
FED_TYPES = ("TOWERLINK_TRANSFORM", "SET_POSITION_TARGET_LOCAL_NED", "TOWERLINK_FOLLOW_STATUS")


class TrackPoints(list):
    """A track segment's points ({"x", "y", "z"} each, m) with their JSON text in `json`: exactly
    what json.dumps makes of the list, joined from each point's text, encoded once when the point
    joined the track (tools.run_mcap.encode takes it as it is: a track is sent again and again)."""

    __slots__ = ("json",)


@dataclass(frozen=True)
class Record:
    """One Foxglove message: topic, sim time (ns), JSON-ready body."""
    topic: str
    sim_ns: int
    body: dict


# ------------------------------------------------------------------- schemas (JSON Schema)

def _obj(**props: Any) -> dict:
    return {"type": "object", "properties": props}


_NUM = {"type": "number"}
_STR = {"type": "string"}
_TIME = _obj(sec={"type": "integer"}, nsec={"type": "integer"})
_VEC = _obj(x=_NUM, y=_NUM, z=_NUM)
_QUAT = _obj(x=_NUM, y=_NUM, z=_NUM, w=_NUM)
_POSE = _obj(position=_VEC, orientation=_QUAT)
_COLOR = _obj(r=_NUM, g=_NUM, b=_NUM, a=_NUM)
_ARR = {"type": "array", "items": {"type": "object"}}
_ENTITY = _obj(timestamp=_TIME, frame_id=_STR, id=_STR, lifetime=_TIME, frame_locked={"type": "boolean"},
               metadata=_ARR, arrows=_ARR, cubes=_ARR, spheres=_ARR, cylinders=_ARR, lines=_ARR,
               triangles=_ARR, texts=_ARR, models=_ARR)

SCHEMAS: dict[str, dict] = {
    "foxglove.FrameTransforms": _obj(transforms={"type": "array", "items": _obj(
        timestamp=_TIME, parent_frame_id=_STR, child_frame_id=_STR, translation=_VEC, rotation=_QUAT)}),
    "foxglove.SceneUpdate": _obj(deletions=_ARR, entities={"type": "array", "items": _ENTITY}),
    "towerlink.Summary": _obj(sim_time=_NUM, follow_error_rms=_NUM, follow_error_max=_NUM,
                              wobble_full_rms=_NUM, wobble_yaw_rms=_NUM, goals_sent={"type": "integer"}),
}
TOPICS: dict[str, str] = {"/tf": "foxglove.FrameTransforms", "/tf_static": "foxglove.FrameTransforms", "/vehicles": "foxglove.SceneUpdate",
                          "/goals": "foxglove.SceneUpdate", "/follow": "foxglove.SceneUpdate",
                          "/summary": "towerlink.Summary"}


def schema_of(topic: str) -> tuple[str, dict]:
    """(schema name, JSON Schema) of a topic this feed writes."""
    name = TOPICS[topic]
    return name, {"title": name, **SCHEMAS[name]}


# ------------------------------------------------------------------- message bodies

def stamp(sim_ns: int) -> dict:
    return {"sec": sim_ns // 1_000_000_000, "nsec": sim_ns % 1_000_000_000}


def frame_transform(sim_ns: int, parent: str, child: str, t, q) -> dict:
    """foxglove.FrameTransform: the pose of `child` in `parent` (tf2's parent -> child), q = x,y,z,w."""
    return {"timestamp": stamp(sim_ns), "parent_frame_id": parent, "child_frame_id": child,
            "translation": {"x": float(t[0]), "y": float(t[1]), "z": float(t[2])},
            "rotation": {"x": float(q[0]), "y": float(q[1]), "z": float(q[2]), "w": float(q[3])}}


def _pose(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> dict:
    return {"position": {"x": x, "y": y, "z": z}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


def _color(rgba) -> dict:
    return dict(zip("rgba", (float(c) for c in rgba)))


def entity(sim_ns: int, frame: str, eid: str, **primitives: list) -> dict:
    """foxglove.SceneEntity in `frame`, replacing any earlier entity with the same id."""
    e = {"timestamp": stamp(sim_ns), "frame_id": frame, "id": eid, "lifetime": stamp(0),
         "frame_locked": True, "metadata": []}
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"):
        e[kind] = primitives.get(kind, [])
    return e


def _cube(size, rgba, x=0.0, y=0.0, z=0.0) -> dict:
    return {"pose": _pose(x, y, z), "size": {"x": size[0], "y": size[1], "z": size[2]}, "color": _color(rgba)}


def _sphere(d: float, rgba, x=0.0, y=0.0, z=0.0) -> dict:
    return {"pose": _pose(x, y, z), "size": {"x": d, "y": d, "z": d}, "color": _color(rgba)}


def _label(text: str, z: float = -1.0) -> dict:
    return {"pose": _pose(0.0, 0.0, z), "billboard": True, "font_size": 14.0, "scale_invariant": True,
            "color": _color((1, 1, 1, 1)), "text": text}


def vehicle_body(frame: str) -> dict[str, list]:
    """Primitives drawn in the vehicle's own frame (x forward, z down): a drone is a cross of
    two arms with a nose; a rover a box with a nose. Colours tell them apart."""
    rgba = FRAME_COLORS.get(frame, (0.8, 0.8, 0.8, 1.0))
    nose = {"pose": _pose(), "shaft_length": 0.6, "shaft_diameter": 0.06, "head_length": 0.25,
            "head_diameter": 0.15, "color": _color((1.0, 0.1, 0.1, 1.0))}
    if frame.startswith("rover"):
        cubes = [_cube((0.8, 0.5, 0.3), rgba, z=-0.15)]
    else:
        cubes = [_cube((1.0, 0.08, 0.05), rgba), _cube((0.08, 1.0, 0.05), rgba)]
    return {"cubes": cubes, "arrows": [nose], "texts": [_label(frame)]}


# ------------------------------------------------------------------- the feed

@dataclass
class _Running:
    n: int = 0
    sum_sq: float = 0.0
    max: float = 0.0

    def add(self, v: float) -> None:
        if math.isfinite(v):
            self.n += 1
            self.sum_sq += v * v
            self.max = max(self.max, v)

    @property
    def rms(self) -> float:
        return math.sqrt(self.sum_sq / self.n) if self.n else 0.0


@dataclass
class SceneFeed:
    """Folds MAVLink messages (arrival order) into Foxglove records on the sim clock.

    Vehicles are drawn for every child of `world` that the tree carries and that is a
    vehicle's body frame (drone, rover, and numbered ones such as drone2), not its yaw-only
    frame: those are drawn by the transforms themselves.
    """
    track_step: float = TRACK_STEP_M
    scene_period: float = SCENE_PERIOD_S
    sim_ns: int = 0
    _boot_ns: dict[int, int] = field(default_factory=dict)
    _tracks: dict[str, list[tuple[float, float, float]]] = field(default_factory=dict)
    _track_texts: dict[str, list[str]] = field(default_factory=dict)     # each point's JSON
    _last_scene: int = -10**18
    _last_resend: float = -1e9
    _last_display: int = -10**18
    _goals: list[tuple[float, float, float]] = field(default_factory=list)
    _follow: tuple | None = None
    _origins: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    _err: _Running = field(default_factory=_Running)
    _wob_full: _Running = field(default_factory=_Running)
    _wob_yaw: _Running = field(default_factory=_Running)

    def feed(self, m) -> list[Record]:
        """Records caused by one message (often none)."""
        t = m.get_type()
        src = m.get_srcSystem()
        ns = self._time_of(m, src)
        if ns is None:
            return []
        self.sim_ns = max(self.sim_ns, ns)
        out: list[Record] = []
        if self.sim_ns - self._last_display >= int(TRACK_RESEND_S * 1e9):
            self._last_display = self.sim_ns
            out.append(Record("/tf_static", self.sim_ns, {"transforms": [
                frame_transform(self.sim_ns, DISPLAY_FRAME, "world", (0.0, 0.0, 0.0), ENU_TO_NED_Q)]}))
        if t == "TOWERLINK_TRANSFORM":
            out += self._transform(m, ns)
        elif t == "SET_POSITION_TARGET_LOCAL_NED" and src == TOWER_SYSID:
            out += self._goal(m, ns)
        elif t == "TOWERLINK_FOLLOW_STATUS":
            self._follow_status(m)
        if self.sim_ns - self._last_scene >= int(self.scene_period * 1e9):   # ns: no float drift
            self._last_scene = self.sim_ns
            out += self._scene(self.sim_ns)
        return out

    def _time_of(self, m, src: int) -> int | None:
        usec = getattr(m, "time_usec", None)
        if isinstance(usec, int) and m.get_type().startswith("TOWERLINK_") and m.get_type() != "TOWERLINK_BRIDGE_STATUS":
            # a static transform says 0: it holds at every time, draw it now
            return usec * 1000 if usec > 0 else self.sim_ns
        ms = getattr(m, "time_boot_ms", None)
        if isinstance(ms, int):
            self._boot_ns[src] = ms * 1_000_000
            return self._boot_ns[src]
        return self._boot_ns.get(src, self.sim_ns if self.sim_ns else None)

    def _transform(self, m, ns: int) -> list[Record]:
        parent, child = mav_str(m.frame_id), mav_str(m.child_frame_id)
        tr, q = m.translation, m.rotation
        if not all(math.isfinite(v) for v in (*tr, *q)):
            return []
        topic = "/tf_static" if m.flags & 1 else "/tf"
        recs = [Record(topic, ns, {"transforms": [frame_transform(ns, parent, child, tr, q)]})]
        if m.flags & 1 and parent == "world" and child.endswith("_origin"):
            self._origins[child] = (float(tr[0]), float(tr[1]), float(tr[2]))
        # a vehicle's pose is in its own origin frame (world -> <vehicle>_origin, static): its
        # track is drawn in world
        off = (0.0, 0.0, 0.0) if parent == "world" else self._origins.get(parent)
        if off is not None and not child.endswith("_yaw") and not m.flags & 1:
            track = self._tracks.setdefault(child, [])
            p = (float(tr[0]) + off[0], float(tr[1]) + off[1], float(tr[2]) + off[2])
            if not track or math.dist(track[-1], p) >= self.track_step:
                track.append(p)
                self._track_texts.setdefault(child, []).append(json.dumps(_track_points((p,))[0]))
        return recs

    def _goal(self, m, ns: int) -> list[Record]:
        return self.add_goal(ns, (float(m.x), float(m.y), float(m.z)))

    def add_goal(self, ns: int, p: tuple[float, float, float]) -> list[Record]:
        """A tower goal, NED in the `tower` frame (from the tower's wire, or its log line live)."""
        if not all(math.isfinite(v) for v in p):
            return []
        if not self._goals or self._goals[-1] != p:
            self._goals.append(p)
        ents = [entity(ns, "tower", f"goal{i + 1}",
                       spheres=[_sphere(1.0, (1.0, 0.85, 0.1, 0.8), *g)],
                       texts=[{**_label(f"goal {i + 1} (tower {g[0]:.1f}, {g[1]:.1f})"),
                               "pose": _pose(g[0], g[1], g[2] - 1.0)}])
                for i, g in enumerate(self._goals)]
        return [Record("/goals", ns, {"deletions": [], "entities": ents})]

    def _follow_status(self, m) -> None:
        self._follow = (m.full_x, m.full_y, m.yaw_x, m.yaw_y, m.goal_x, m.goal_y)
        if m.state:
            self._err.add(math.hypot(m.rover_x - m.ref_x, m.rover_y - m.ref_y))
            self._wob_full.add(float(m.err_full))
            self._wob_yaw.add(float(m.err_yaw))

    def _scene(self, ns: int) -> list[Record]:
        ents = []
        resend = ns / 1e9 - self._last_resend >= TRACK_RESEND_S
        if resend:
            self._last_resend = ns / 1e9
        for frame, track in self._tracks.items():
            ents.append(entity(ns, frame, frame, **vehicle_body(frame)))
            last = (len(track) - 1) // TRACK_SEGMENT
            texts = self._track_texts[frame]
            for k in range(0 if resend else last, last + 1):
                part = slice(k * TRACK_SEGMENT, (k + 1) * TRACK_SEGMENT + 1)   # segments share an end point
                seg = track[part]
                if len(seg) >= 2:
                    ents.append(self._track_entity(ns, frame, k, seg, texts[part]))
        recs = [Record("/vehicles", ns, {"deletions": [], "entities": ents})] if ents else []
        if self._follow is not None:
            fx, fy, yx, yy, gx, gy = (float(v) for v in self._follow)
            fol = entity(ns, "world", "rover_target", spheres=[
                _sphere(0.5, (1.0, 0.2, 0.2, 0.9), fx, fy, 0.0),     # through the full-attitude frame
                _sphere(0.5, (0.2, 1.0, 0.3, 0.9), yx, yy, 0.0)],    # through the yaw-only frame
                texts=[{**_label("full attitude"), "pose": _pose(fx, fy, -0.8)},
                       {**_label("yaw only"), "pose": _pose(yx, yy, -1.6)}])
            recs.append(Record("/follow", ns, {"deletions": [], "entities": [fol]}))
        recs.append(Record("/summary", ns, {
            "sim_time": ns / 1e9, "follow_error_rms": self._err.rms, "follow_error_max": self._err.max,
            "wobble_full_rms": self._wob_full.rms, "wobble_yaw_rms": self._wob_yaw.rms,
            "goals_sent": len(self._goals)}))
        return recs

    @staticmethod
    def _track_entity(ns: int, frame: str, k: int, seg, texts: list[str]) -> dict:
        rgba = FRAME_COLORS.get(frame, (0.8, 0.8, 0.8, 1.0))
        points = TrackPoints(_track_points(seg))
        points.json = f"[{', '.join(texts)}]"
        return entity(ns, "world", f"track_{frame}_{k}", lines=[{
            "type": 0, "pose": _pose(), "thickness": 0.08, "scale_invariant": False,
            "points": points, "color": _color(rgba), "colors": [], "indices": []}])


def _track_points(seg) -> list[dict]:
    return [{"x": x, "y": y, "z": z} for x, y, z in seg]


def records_of(msgs: Iterable[Any], feed: SceneFeed | None = None) -> Iterator[Record]:
    """Every record a message stream gives, in its order."""
    feed = feed or SceneFeed()
    for m in msgs:
        yield from feed.feed(m)
