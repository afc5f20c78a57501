"""Scoring a run: minimum times, follow error and the wobble figure, from the run's tlogs.

A run folder (written by `towerlink fly`) holds:

  vehicles.tlog  the fly launcher's own link to the SITL world: both vehicles'
                 telemetry incl. SIM_STATE (truth), PARAM_VALUE, HOME_POSITION
  bridge.tlog    the bridge's transform stream: TOWERLINK_TRANSFORM,
                 TOWERLINK_FOLLOW_STATUS, TOWERLINK_BRIDGE_STATUS
  tower.tlog     the tower's link to the bridge (both directions, tower frame)
  tower.json     the tower's mission result (goals, sim times)

Everything here is pure data work (no sockets) so it is unit-tested and re-run
offline: `summarize(run_dir)` returns a dict (summary.json) and
`format_summary(d)` the text a person reads.

Times are sim seconds from the vehicles' clocks (time_boot_ms); a message without
its own stamp (SIM_STATE) takes the newest time_boot_ms its system sent before it.
"""
from __future__ import annotations

import json
import math
import os
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from common.frames.batch import ground_point
from common.geo import lla_to_ned, ned_to_lla
from common.mavlink.mavstr import mav_str

os.environ.setdefault("MAVLINK20", "1")

DRONE, ROVER = 1, 2
# ArduPilot Copter defaults, used when the tlog holds no PARAM_VALUE for them.
PARAM_DEFAULTS = {"WPNAV_SPEED": 500.0, "WPNAV_ACCEL": 250.0, "PSC_JERK_XY": 5.0}


# ----------------------------------------------------------------------------- minimum time


RESOLUTION_M = 1e-3   # m: errors below this are reported as "below 1 mm"


def minimum_time(d: float, v: float, a: float, j: float) -> float:
    """Shortest rest-to-rest time over distance d with speed v, acceleration a, jerk j limits.

    The symmetric jerk-limited (S-curve) profile. For long moves (the cruise speed v
    and the acceleration a are both reached) this is the design's d/v + v/a + a/j;
    shorter moves peak below v (and, shorter still, below a), and the time is
    solved exactly for those cases so the ratio stays meaningful on short legs.
    """
    if d < 0 or v <= 0 or a <= 0 or j <= 0:
        raise ValueError("minimum_time needs d >= 0 and v, a, j > 0")
    if d == 0:
        return 0.0

    def t_acc(vp: float) -> float:   # time to go from rest to vp (and the same to stop)
        return vp / a + a / j if vp >= a * a / j else 2.0 * math.sqrt(vp / j)

    # distance of accelerating to vp and back to rest: vp * t_acc(vp)
    if v * t_acc(v) <= d:
        return d / v + t_acc(v)
    # no cruise: the peak speed vp solves vp * t_acc(vp) = d
    vp = a / 2.0 * (-(a / j) + math.sqrt((a / j) ** 2 + 4.0 * d / a))
    if vp < a * a / j:                          # acceleration limit not reached either
        vp = (d * math.sqrt(j) / 2.0) ** (2.0 / 3.0)
    return 2.0 * t_acc(vp)


# ----------------------------------------------------------------------------- tlogs


def read_tlog(path: str | os.PathLike) -> Iterator[Any]:
    """Every message of a tlog, decoded with the towerlink dialect (ardupilotmega if absent)."""
    try:
        from common.mavlink.dialect import mavlink_connection
    except ImportError:  # pragma: no cover
        from pymavlink.mavutil import mavlink_connection
    conn = mavlink_connection(str(path))
    try:
        while True:
            m = conn.recv_msg()
            if m is None:
                return
            if m.get_type() != "BAD_DATA":
                yield m
    finally:
        conn.close()


@dataclass
class Track:
    """A time series for one system: t (N,), xyz (N,3) world NED, extra columns by name."""
    t: np.ndarray
    xyz: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)

    def at(self, t: float | np.ndarray) -> np.ndarray:
        """Position interpolated linearly at sim time(s) t (clamped to the ends)."""
        return np.stack([np.interp(t, self.t, self.xyz[:, k]) for k in range(3)], axis=-1)

    def window(self, t0: float | None, t1: float | None) -> "Track":
        m = np.ones(len(self.t), bool)
        if t0 is not None:
            m &= self.t >= t0
        if t1 is not None:
            m &= self.t <= t1
        return Track(self.t[m], self.xyz[m], {k: v[m] for k, v in self.extra.items()})


def _track(rows: list[tuple], extra_names: tuple[str, ...] = ()) -> Track:
    if not rows:
        return Track(np.zeros(0), np.zeros((0, 3)), {n: np.zeros(0) for n in extra_names})
    a = np.array(rows, dtype=float)
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    # drop duplicate stamps (keep the last)
    keep = np.append(np.diff(a[:, 0]) > 0, True)
    a = a[keep]
    return Track(a[:, 0], a[:, 1:4], {n: a[:, 4 + i] for i, n in enumerate(extra_names)})


@dataclass
class RunData:
    """What the scorer reads from a run's tlogs."""
    truth: dict[int, Track] = field(default_factory=dict)      # SIM_STATE, world NED
    estimate: dict[int, Track] = field(default_factory=dict)   # LOCAL_POSITION_NED, world
    params: dict[int, dict[str, float]] = field(default_factory=dict)
    follow: dict[str, np.ndarray] = field(default_factory=dict)  # TOWERLINK_FOLLOW_STATUS columns
    transforms: dict[tuple[str, str], list[tuple[float, tuple]]] = field(default_factory=dict)
    statics: dict[tuple[str, str], tuple] = field(default_factory=dict)
    bridge_status: dict[str, dict[str, int]] = field(default_factory=dict)
    follow_frame: int | None = None


FOLLOW_FIELDS = ("t", "ref_x", "ref_y", "full_x", "full_y", "yaw_x", "yaw_y", "goal_x", "goal_y",
                 "rover_x", "rover_y", "height", "tilt", "err_full", "err_yaw", "follow_frame", "state")


def load_messages(msgs: Iterable[Any], data: RunData | None = None) -> RunData:
    """Fold a message stream (one tlog, or several one after the other) into RunData."""
    data = data or RunData()
    last_ms: dict[int, int] = defaultdict(int)
    origin: dict[int, tuple[float, float, float]] = {}
    home: dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]] = {}
    truth_lla: dict[int, list] = defaultdict(list)
    est_rows: dict[int, list] = defaultdict(list)
    follow_rows: list = []
    for m in msgs:
        t = m.get_type()
        src = m.get_srcSystem()
        ms = getattr(m, "time_boot_ms", None)
        if isinstance(ms, int) and t != "SET_POSITION_TARGET_LOCAL_NED" and t != "TOWERLINK_POSITION_TARGET":
            last_ms[src] = max(last_ms[src], ms) if ms + 5000 > last_ms[src] else ms
        if t == "SIM_STATE":
            lat = m.lat_int * 1e-7 if getattr(m, "lat_int", 0) else m.lat
            lon = m.lon_int * 1e-7 if getattr(m, "lon_int", 0) else m.lon
            truth_lla[src].append((last_ms[src] / 1000.0, lat, lon, m.alt, m.roll, m.pitch, m.yaw,
                                   m.vn, m.ve, m.vd))
        elif t == "LOCAL_POSITION_NED":
            est_rows[src].append((m.time_boot_ms / 1000.0, m.x, m.y, m.z, m.vx, m.vy, m.vz))
        elif t == "GPS_GLOBAL_ORIGIN":
            origin[src] = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
        elif t == "HOME_POSITION":
            home[src] = ((m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3), (m.x, m.y, m.z))
        elif t == "PARAM_VALUE":
            data.params.setdefault(src, {})[mav_str(m.param_id)] = float(m.param_value)
        elif t == "TOWERLINK_FOLLOW_STATUS":
            follow_rows.append((m.time_usec * 1e-6, m.ref_x, m.ref_y, m.full_x, m.full_y, m.yaw_x,
                                m.yaw_y, m.goal_x, m.goal_y, m.rover_x, m.rover_y, m.height, m.tilt,
                                m.err_full, m.err_yaw, m.follow_frame, m.state))
        elif t == "TOWERLINK_TRANSFORM":
            key = (mav_str(m.frame_id), mav_str(m.child_frame_id))
            v = tuple(float(x) for x in (*m.translation, *m.rotation))
            if m.flags & 1:
                data.statics[key] = v
            else:
                data.transforms.setdefault(key, []).append((m.time_usec * 1e-6, v))
        elif t == "TOWERLINK_BRIDGE_STATUS":
            data.bridge_status[mav_str(m.link)] = {k: int(getattr(m, k)) for k in
                                              ("rx_packets", "tx_packets", "malformed", "unroutable",
                                               "translated", "deferred")}
    # each vehicle's local NED is centred on its own EKF origin; world is the first vehicle's
    # (the drone's), as the bridge's world is by default
    local0 = {src: _local_origin(origin.get(src), home.get(src)) for src in set(origin) | set(home)}
    local0 = {k: v for k, v in local0.items() if v is not None}
    ref = local0[min(local0)] if local0 else None
    for src, rows in truth_lla.items():
        if ref is None or src not in local0:
            continue
        out = []
        for (tt, lat, lon, alt, r, p, y, vn, ve, vd) in rows:
            n, e, d = lla_to_ned(ref, lat, lon, alt)
            out.append((tt, n, e, d, r, p, y, vn, ve, vd))
        data.truth[src] = _track(out, ("roll", "pitch", "yaw", "vn", "ve", "vd"))
    for src, rows in est_rows.items():
        if ref is not None and src in local0:
            off = lla_to_ned(ref, *local0[src])
            rows = [(tt, x + off[0], y + off[1], z + off[2], *v) for (tt, x, y, z, *v) in rows]
        data.estimate[src] = _track(rows, ("vx", "vy", "vz"))
    if follow_rows:
        a = np.array(follow_rows, dtype=float)
        a = a[np.argsort(a[:, 0], kind="stable")]
        data.follow = {k: a[:, i] for i, k in enumerate(FOLLOW_FIELDS)}
        data.follow_frame = int(a[-1, FOLLOW_FIELDS.index("follow_frame")])
    return data


def _local_origin(origin, home):
    """Where a vehicle's local NED is centred (lat, lon, alt): its GPS_GLOBAL_ORIGIN, else
    HOME_POSITION's lla less its local x, y, z; None if neither was logged."""
    if origin is not None:
        return origin
    if home is not None:
        lla, xyz = home
        return ned_to_lla(lla, (-xyz[0], -xyz[1], -xyz[2]))
    return None


def load_run(run_dir: str | os.PathLike) -> RunData:
    """Read every tlog of a run folder (vehicles, bridge, tower) into one RunData."""
    run_dir = Path(run_dir)
    data = RunData()
    vehicles = run_dir / "vehicles.tlog"
    if vehicles.exists():
        load_messages(read_tlog(vehicles), data)
    bridge = run_dir / "bridge.tlog"
    if bridge.exists():
        msgs = read_tlog(bridge)
        if vehicles.exists():  # the bridge's out link repeats the vehicles' traffic: take its own
            msgs = (m for m in msgs if m.get_type().startswith("TOWERLINK_"))
        load_messages(msgs, data)
    return data


# ----------------------------------------------------------------------------- scoring


def rms(x: np.ndarray) -> float:
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def horizontal_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def _follow_error(drone_truth, rover_truth, t0, t1) -> dict[str, Any]:
    """Horizontal distance from a rover to the point under the drone, on truth, over the mission."""
    if drone_truth is None or rover_truth is None or not len(drone_truth) or not len(rover_truth):
        return {}
    rt = rover_truth.window(t0, t1)
    keep = (rt.t >= drone_truth.t[0]) & (rt.t <= drone_truth.t[-1])
    rt = Track(rt.t[keep], rt.xyz[keep])
    err = horizontal_error(rt.xyz, drone_truth.at(rt.t))
    return {"source": "truth (SIM_STATE)", **_stat(err)}


def world_transforms(data: RunData, child: str, vehicle: str = "drone") -> list[tuple[float, tuple]]:
    """The recorded transforms world -> `child`: the bridge's <vehicle>_origin -> child moved by
    the static world -> <vehicle>_origin (a translation, from GPS_GLOBAL_ORIGIN); tlogs from
    before the origin frames have world -> child itself."""
    origin = vehicle + "_origin"
    rows = data.transforms.get((origin, child))
    off = data.statics.get(("world", origin))
    if not rows or off is None:
        return data.transforms.get(("world", child), [])
    ox, oy, oz = off[:3]
    return [(t, (v[0] + ox, v[1] + oy, v[2] + oz, *v[3:])) for t, v in rows]


def ground_point_errors(transforms: list[tuple[float, tuple]]) -> tuple[np.ndarray, np.ndarray]:
    """Attitude-caused ground-point error of each recorded world -> drone-frame transform.

    The ground point is (0, 0, h) in the drone frame, h = the drone's height (-z of its
    origin in world), mapped to world (common.frames.batch.ground_point, the follow's own);
    its horizontal distance from the frame's own origin is what the attitude adds
    (h·sin(tilt) for a full-attitude frame, 0 for a yaw-only one). Returns (stamps, errors).
    """
    if not transforms:
        return np.zeros(0), np.zeros(0)
    a = np.array([(t, *v) for t, v in transforms], float)
    t, xyz, q = a[:, 0], a[:, 1:4], a[:, 4:8]
    gp = ground_point(xyz, q, -xyz[:, 2])
    return t, np.hypot(gp[:, 0] - xyz[:, 0], gp[:, 1] - xyz[:, 1])


def _stat(x: np.ndarray) -> dict[str, float | int]:
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return {"rms": None, "max": None, "n": 0}
    return {"rms": rms(x), "max": float(np.max(x)), "n": int(x.size)}


def summarize(run_dir: str | os.PathLike, *, data: RunData | None = None,
              tower: dict | None = None, scenario_path: str | None = None,
              meta: dict | None = None) -> dict:
    """Score one run; returns the dict written as summary.json."""
    run_dir = Path(run_dir)
    data = data if data is not None else load_run(run_dir)
    if tower is None:
        p = run_dir / "tower.json"
        tower = json.loads(p.read_text()) if p.exists() else {"goals": []}
    meta = dict(meta or {})
    if meta.get("scenario") is None and (run_dir / "meta.json").exists():
        meta = {**json.loads((run_dir / "meta.json").read_text()), **meta}
    scenario_path = scenario_path or meta.get("scenario")

    # world coordinates of the goals, from the scenario's static frames
    from common.frames import PointStamped  # noqa: F401  (documented API)
    from common.scenario import load_scenario
    sc = load_scenario(scenario_path)
    buf = sc.buffer()
    goal_frame = tower["goals"][0]["frame"] if tower.get("goals") else sc.goal_frame
    to_world = buf.lookup_transform("world", goal_frame).transform

    params = {**PARAM_DEFAULTS, **data.params.get(DRONE, {})}
    assumed = sorted(k for k in PARAM_DEFAULTS if k not in data.params.get(DRONE, {}))
    v = params["WPNAV_SPEED"] / 100.0
    a = params["WPNAV_ACCEL"] / 100.0
    j = params["PSC_JERK_XY"]

    drone_truth = data.truth.get(DRONE)
    rover_truth = data.truth.get(ROVER)
    goals_out = []
    prev_world = None
    if tower.get("takeoff_position") is not None:
        prev_world = to_world.apply_point(np.array(tower["takeoff_position"], float))
    for g in tower.get("goals", []):
        gw = to_world.apply_point(np.array(g["goal"], float))
        leg = float(np.hypot(*(gw[:2] - prev_world[:2]))) if prev_world is not None else None
        tmin = minimum_time(leg, v, a, j) if leg is not None else None
        ttr = g.get("time_to_reach")
        rover_err = None
        if g.get("reached") and drone_truth is not None and rover_truth is not None \
                and len(drone_truth) and len(rover_truth):
            tr = g["reached_sim"]
            rover_err = float(horizontal_error(rover_truth.at(tr), drone_truth.at(tr)))
        goals_out.append({
            "index": g["index"], "tower": list(g["goal"]), "world": [float(x) for x in gw],
            "reached": bool(g.get("reached")), "time_to_reach": ttr, "leg_m": leg,
            "min_time": tmin,
            "ratio": (ttr / tmin) if (ttr is not None and tmin) else None,
            "rover_error_at_arrival": rover_err, "sends": g.get("sends"),
            "error": g.get("error"),
        })
        prev_world = gw

    # mission window: first goal sent .. last goal reached (or the end)
    sent = [g["sent_sim"] for g in tower.get("goals", []) if g.get("sent_sim") is not None]
    done = [g["reached_sim"] for g in tower.get("goals", []) if g.get("reached_sim") is not None]
    t0 = min(sent) if sent else None
    t1 = max(done) if done else tower.get("end_sim")

    follow: dict[str, Any] = {}
    # who followed: the bridge's tf follow (rover sysid 2), or ArduPilot's FOLLOW mode on sysid 2
    # (fly --follow-with ardupilot) or on a second rover, sysid 3 (--follow-with both)
    ap_sysid = meta.get("ardupilot_follower")
    follow_ap: dict[str, Any] = {}
    if ap_sysid not in (None, ROVER):
        follow_ap = _follow_error(drone_truth, data.truth.get(ap_sysid), t0, t1)
        if follow_ap:
            follow_ap["by"] = f"ArduPilot FOLLOW (sysid {ap_sysid})"
    if drone_truth is not None and rover_truth is not None and len(drone_truth) and len(rover_truth):
        follow = _follow_error(drone_truth, rover_truth, t0, t1)
        follow["by"] = "ArduPilot FOLLOW (sysid 2)" if ap_sysid == ROVER else "bridge tf follow (sysid 2)"
    elif data.follow:  # no truth recorded: the bridge's view (telemetry estimates)
        f = data.follow
        m = _in(f["t"], t0, t1) & np.isfinite(f["rover_x"])
        err = np.hypot(f["rover_x"][m] - f["ref_x"][m], f["rover_y"][m] - f["ref_y"][m])
        follow = {"source": "bridge telemetry", **_stat(err)}

    wobble: dict[str, Any] = {}
    if data.follow:
        f = data.follow
        m = _in(f["t"], t0, t1)
        full, yaw = _stat(f["err_full"][m]), _stat(f["err_yaw"][m])
        wobble = {"source": "bridge follow ticks (TOWERLINK_FOLLOW_STATUS)", "drone": full,
                  "drone_yaw": yaw, "height_mean": _mean(f["height"][m]),
                  "tilt_max_deg": _max(np.degrees(f["tilt"][m]))}
        if data.follow_frame is not None:
            wobble["follow_frame"] = ("drone", "drone_yaw")[data.follow_frame] \
                if data.follow_frame in (0, 1) else str(data.follow_frame)
    tfw: dict[str, Any] = {}
    for child in ("drone", "drone_yaw"):
        ts, e = ground_point_errors(world_transforms(data, child))
        if ts.size:
            tfw[child] = _stat(e[_in(ts, t0, t1)])
    if tfw:
        wobble["from_transforms"] = tfw
        if "drone" not in wobble and "drone" in tfw:
            wobble.update({"source": "recorded world->drone transforms", **tfw})
    if wobble.get("drone") and wobble.get("drone_yaw") and wobble["drone"]["rms"] is not None:
        wobble["ratio_rms"] = _ratio(wobble["drone"]["rms"], wobble["drone_yaw"]["rms"])
        wobble["ratio_max"] = _ratio(wobble["drone"]["max"], wobble["drone_yaw"]["max"])

    flight: dict[str, Any] = {}
    if drone_truth is not None and len(drone_truth):
        dt = drone_truth.window(t0, t1)
        if len(dt):
            sp = np.hypot(dt.extra["vn"], dt.extra["ve"])
            tilt = np.degrees(np.arccos(np.clip(np.cos(dt.extra["roll"]) * np.cos(dt.extra["pitch"]), -1, 1)))
            flight = {"max_speed": float(sp.max()), "mean_height": float(-dt.xyz[:, 2].mean()),
                      "max_tilt_deg": float(tilt.max())}

    from tools.hover_stats import hover_figures
    hover = hover_figures(data, DRONE, until=tower.get("end_sim"))     # not the tail fly records while stopping
    hover["wind"] = list(sc.wind) if sc.wind else None

    reached = sum(g["reached"] for g in goals_out)
    out = {
        "ok": bool(tower.get("ok")) and reached == len(goals_out) and reached > 0,
        "scenario": sc.name, "goals_reached": reached, "goals_total": len(goals_out),
        "goals": goals_out, "follow_error": follow, "follow_error_ardupilot": follow_ap, "wobble": wobble, "flight": flight, "hover": hover,
        "limits": {"WPNAV_SPEED": v, "WPNAV_ACCEL": a, "PSC_JERK_XY": j},
        "limits_assumed": assumed,      # not read from the drone (no PARAM_VALUE): Copter defaults
        "mission_window_sim": [t0, t1],
        "bridge_status": data.bridge_status, "tower_error": tower.get("error"),
    }
    out.update({k: meta[k] for k in meta if k not in out})
    return out


def _in(t: np.ndarray, t0, t1) -> np.ndarray:
    m = np.ones(len(t), bool)
    if t0 is not None:
        m &= t >= t0
    if t1 is not None:
        m &= t <= t1
    return m


def _mean(x):
    x = np.asarray(x, float)
    return float(x.mean()) if x.size else None


def _max(x):
    x = np.asarray(x, float)
    return float(x.max()) if x.size else None


def _ratio(big, small):
    if big is None or small is None:
        return None
    return float(big / max(small, 1e-6))


# ----------------------------------------------------------------------------- text


def _f(x, spec=".2f", none="-"):
    return none if x is None else format(x, spec)


def format_summary(s: dict) -> str:
    """The at-a-glance text of a summary dict."""
    lines = []
    status = "MISSION OK" if s.get("ok") else "MISSION FAILED"
    head = f"{status}: {s.get('goals_reached', 0)}/{s.get('goals_total', 0)} goals reached"
    bits = [f"scenario {s.get('scenario')}"]
    if s.get("seed") is not None:
        bits.append(f"seed {s['seed']}")
    if s.get("speedup") is not None:
        sp = f"speedup {s['speedup']:g}x" if isinstance(s["speedup"], (int, float)) else f"speedup {s['speedup']}"
        if s.get("achieved_speedup"):
            sp += f" (achieved {s['achieved_speedup']:.1f}x)"
        bits.append(sp)
    if s.get("follow_frame"):
        bits.append(f"rover follows {s['follow_frame']}")
    lines.append(head + "  |  " + ", ".join(bits))
    lim = s.get("limits", {})
    lines.append(f"minimum time d/v + v/a + a/j with v {lim.get('WPNAV_SPEED', 0):g} m/s, "
                 f"a {lim.get('WPNAV_ACCEL', 0):g} m/s², j {lim.get('PSC_JERK_XY', 0):g} m/s³ "
                 "(exact S-curve on short legs); reach = first sample within the radius, "
                 "before the drone has stopped, so a ratio can dip just under 1")
    if s.get("limits_assumed"):
        lines.append(f"WARNING: {', '.join(s['limits_assumed'])} not read from the drone (no PARAM_VALUE in "
                     "the tlog): ArduPilot Copter's defaults assumed for the minimum times")
    lines.append("")
    lines.append(f"  {'goal':>5}  {'tower [x, y]':>18}  {'world [x, y]':>16}  {'leg m':>6}  "
                 f"{'reach s':>7}  {'min s':>6}  {'ratio':>5}  {'rover m':>7}")
    n = s.get("goals_total", 0)
    for g in s.get("goals", []):
        tw = f"[{g['tower'][0]:8.2f}, {g['tower'][1]:7.2f}]"
        wd = f"[{g['world'][0]:6.2f}, {g['world'][1]:6.2f}]"
        if g["reached"]:
            reach = _f(g["time_to_reach"], "7.2f")
        else:
            reach = "MISSED".rjust(7)
        lines.append(f"  {g['index']:>2}/{n:<2}  {tw:>18}  {wd:>16}  {_f(g['leg_m'], '6.1f'):>6}  "
                     f"{reach:>7}  {_f(g['min_time'], '6.2f'):>6}  {_f(g['ratio'], '5.2f'):>5}  "
                     f"{_f(g['rover_error_at_arrival'], '7.2f'):>7}")
    lines.append("")
    fe = s.get("follow_error") or {}
    fa = s.get("follow_error_ardupilot") or {}
    if fe.get("n"):
        by = f" by {fe['by']}" if fe.get("by") else ""
        lines.append(f"rover follow error{by} (rover vs drone ground point, {fe['source']}, over the mission): "
                     f"RMS {fe['rms']:.2f} m, max {fe['max']:.2f} m")
        if fa.get("n"):
            lines.append(f"rover follow error by {fa['by']} (same flight, {fa['source']}): "
                         f"RMS {fa['rms']:.2f} m, max {fa['max']:.2f} m")
    else:
        lines.append("rover follow error: not measured (no truth in the tlogs)")
    w = s.get("wobble") or {}
    fl = s.get("flight") or {}
    if w.get("drone") and w["drone"].get("n"):
        ctx = []
        if fl.get("max_speed") is not None:
            ctx.append(f"max speed {fl['max_speed']:.1f} m/s")
        h = fl.get("mean_height") or w.get("height_mean")
        if h is not None:
            ctx.append(f"height {h:.1f} m")
        tilt = fl.get("max_tilt_deg") or w.get("tilt_max_deg")
        if tilt is not None:
            ctx.append(f"max tilt {tilt:.1f}°")
        lines.append("wobble: ground-point error caused by attitude" + (f" ({', '.join(ctx)})" if ctx else ""))
        d, y = w["drone"], w["drone_yaw"]
        lines.append(f"  full attitude  (drone)      RMS {d['rms']:.3f} m, max {d['max']:.3f} m")
        ratio = w.get("ratio_rms")
        if ratio is None:
            rtxt = ""
        elif y["rms"] < RESOLUTION_M:
            # the yaw-only point has no attitude term: what is left is float rounding, so
            # the honest ratio is a lower bound against a millimetre
            rtxt = f"   -> over {d['rms'] / RESOLUTION_M:,.0f}x smaller (RMS; yaw-only below 1 mm)"
        else:
            rtxt = f"   -> {ratio:,.1f}x smaller (RMS)"
        lines.append(f"  yaw-only       (drone_yaw)  RMS {y['rms']:.3f} m, max {y['max']:.3f} m{rtxt}")
    else:
        lines.append("wobble: not measured (no follow ticks or drone transforms recorded)")
    if s.get("hover") is not None:
        from tools.hover_stats import format_hover
        h = dict(s["hover"])
        wind = h.pop("wind", None)
        lines.extend(format_hover(h, wind))
    if s.get("tower_error"):
        lines.append(f"tower: {s['tower_error']}")
    return "\n".join(lines)
