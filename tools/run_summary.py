"""Scoring a run: the summary of one `towerlink fly` run, and its text.

The run folder's tlogs (read by tools.run_data) and tower.json (the tower's mission result:
goals, sim times) give per goal its tower and world coordinates, time to reach and the ratio
to the minimum time; the rover's follow error; the wobble figure; the hover figures; and with
faults.json (the link proxy's record) each fault and the failsafes it caused (tools.fault_summary).
`summarize(run_dir)` returns a dict (summary.json) and `format_summary(d)` the text a
person reads. Pure data work (no sockets): unit-tested and re-run offline.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from tools.fault_summary import fault_section, format_faults
from tools.hover_stats import format_hover, hover_figures
from tools.run_data import DRONE, ROVER, RunData, Track, load_run
from tools.run_figures import (PARAM_DEFAULTS, ground_point_errors, horizontal_error, in_window, minimum_time,
                               stat, world_transforms)

RESOLUTION_M = 1e-3   # m: errors below this are reported as "below 1 mm"


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
        follow["by"] = follower(meta, ap_sysid)
    elif data.follow:  # no truth recorded: the bridge's view (telemetry estimates)
        f = data.follow
        m = in_window(f["t"], t0, t1) & np.isfinite(f["rover_x"])
        err = np.hypot(f["rover_x"][m] - f["ref_x"][m], f["rover_y"][m] - f["ref_y"][m])
        follow = {"source": "bridge telemetry", **stat(err)}

    wobble: dict[str, Any] = {}
    if data.follow:
        f = data.follow
        m = in_window(f["t"], t0, t1)
        full, yaw = stat(f["err_full"][m]), stat(f["err_yaw"][m])
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
            tfw[child] = stat(e[in_window(ts, t0, t1)])
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

    hover = hover_figures(data, DRONE, until=tower.get("end_sim"))     # not the tail fly records while stopping
    hover["wind"] = list(sc.wind) if sc.wind else None

    names = {sysid: name for name, sysid, _kind in sc.vehicles}
    faults = fault_section(sc.faults, read_applied(run_dir), data, names, tower.get("goals", []),
                           end=tower.get("end_sim"))
    reached = sum(g["reached"] for g in goals_out)
    out = {
        "ok": bool(tower.get("ok")) and reached == len(goals_out) and reached > 0,
        "scenario": sc.name, "goals_reached": reached, "goals_total": len(goals_out),
        "goals": goals_out, "follow_error": follow, "follow_error_ardupilot": follow_ap, "wobble": wobble, "flight": flight, "hover": hover,
        "limits": {"WPNAV_SPEED": v, "WPNAV_ACCEL": a, "PSC_JERK_XY": j},
        "limits_assumed": assumed,      # not read from the drone (no PARAM_VALUE): Copter defaults
        "mission_window_sim": [t0, t1],
        "bridge_status": data.bridge_status, "tower_error": tower.get("error"), "faults": faults,
    }
    out.update({k: meta[k] for k in meta if k not in out})
    return out


def read_applied(run_dir: str | os.PathLike) -> list[dict]:
    """When each fault took effect and was cleared (faults.json "applied"; [] without one)."""
    p = Path(run_dir) / "faults.json"
    if not p.exists():
        return []
    return list(json.loads(p.read_text()).get("applied", []))


def follower(meta: dict, ap_sysid: int | None) -> str:
    """Who made rover sysid 2 follow the drone: ArduPilot's FOLLOW mode on it, the lab's nodes
    (fly --nodes: a node sends the rover its goals), or the bridge's tf follow."""
    if ap_sysid == ROVER:
        return "ArduPilot FOLLOW (sysid 2)"
    if meta.get("nodes"):
        return f"the nodes' follow ({', '.join(meta['nodes'])}) (sysid 2)"
    return "bridge tf follow (sysid 2)"


def _follow_error(drone_truth, rover_truth, t0, t1) -> dict[str, Any]:
    """Horizontal distance from a rover to the point under the drone, on truth, over the mission."""
    if drone_truth is None or rover_truth is None or not len(drone_truth) or not len(rover_truth):
        return {}
    rt = rover_truth.window(t0, t1)
    keep = (rt.t >= drone_truth.t[0]) & (rt.t <= drone_truth.t[-1])
    rt = Track(rt.t[keep], rt.xyz[keep])
    err = horizontal_error(rt.xyz, drone_truth.at(rt.t))
    return {"source": "truth (SIM_STATE)", **stat(err)}


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
        h = dict(s["hover"])
        wind = h.pop("wind", None)
        lines.extend(format_hover(h, wind))
    lines.extend(format_faults(s.get("faults")))
    if s.get("tower_error"):
        lines.append(f"tower: {s['tower_error']}")
    return "\n".join(lines)
