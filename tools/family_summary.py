"""The summary of a family or van run: a row per vehicle, a row per goal, separation.

Read from the run folder (tlogs as tools.run_data reads them, tower.json as
gcs.tower.run_family writes it). All positions are world NED, m, from truth
(SIM_STATE) when recorded, else the vehicles' LOCAL_POSITION_NED; times are sim s. Every
figure ends with the tower (its last drone's end_sim), not with the recording.

* vehicles: name, sysid, role, path length, highest point; a drone's goals reached and
  mean time to reach; a rover's follow error (horizontal, against its drone's ground
  point, RMS and max over its drone's mission: first goal sent .. last goal reached).
* goals: per drone, tower and world coordinates, time to reach; with the tower on a
  moving frame, the world point it was resolved to at its stamp and how far the same
  tower coordinates would have landed with the latest transform when it was reached.
* separation: the closest 3-D approach of two airborne drones (more than 1 m above
  their start), from truth, and the tower's own watch figure.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from tools.run_data import RunData, Track, load_run
from tools.run_figures import horizontal_error, rms

AIRBORNE_M = 1.0


def _path_len(tr: Track) -> float:
    return float(np.sum(np.linalg.norm(np.diff(tr.xyz, axis=0), axis=1))) if len(tr) > 1 else 0.0


def closest_approach(tracks: dict[str, Track], airborne: float = AIRBORNE_M) -> dict[str, Any]:
    """Smallest 3-D distance between two drones while both are above `airborne` m (world NED)."""
    best: dict[str, Any] = {"closest_m": None, "pair": None, "t": None}
    names = sorted(tracks)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            ta, tb = tracks[a], tracks[b]
            if len(ta) < 2 or len(tb) < 2:
                continue
            t = ta.t[(ta.t >= tb.t[0]) & (ta.t <= tb.t[-1])]
            if not t.size:
                continue
            pa, pb = ta.at(t), tb.at(t)
            up = (ta.xyz[0, 2] - pa[:, 2] > airborne) & (tb.xyz[0, 2] - pb[:, 2] > airborne)
            if not up.any():
                continue
            d = np.linalg.norm(pa[up] - pb[up], axis=1)
            k = int(np.argmin(d))
            if best["closest_m"] is None or d[k] < best["closest_m"]:
                best = {"closest_m": float(d[k]), "pair": [a, b], "t": float(t[up][k])}
    return best


def summarize_family(run_dir: str | os.PathLike, *, tower: dict | None = None,
                     scenario_path: str | None = None, meta: dict | None = None,
                     data: RunData | None = None) -> dict:
    """Score a family / van run; the dict written as summary.json."""
    import json

    from common.scenario import load_scenario
    run_dir = Path(run_dir)
    data = data if data is not None else load_run(run_dir)
    if tower is None:
        p = run_dir / "tower.json"
        tower = json.loads(p.read_text()) if p.exists() else {"drones": []}
    sc = load_scenario(scenario_path)
    tracks = {sysid: (data.truth.get(sysid) if data.truth.get(sysid) is not None and len(data.truth[sysid])
                      else data.estimate.get(sysid)) for _n, sysid, _k in sc.vehicles}
    # the run ends with the tower (its last drone's end_sim): what is recorded after that, while
    # fly stops the processes, lasts as long as the machine takes, so it is no figure's
    ends = [d["end_sim"] for d in tower.get("drones", []) if d.get("end_sim") is not None]
    if ends:
        tracks = {s: tr.window(None, max(ends)) if tr is not None else None for s, tr in tracks.items()}
    source = "truth (SIM_STATE)" if data.truth else "vehicle estimates"
    static_world = None
    try:
        static_world = sc.buffer().lookup_transform("world", sc.goal_frame).transform
    except Exception:  # noqa: BLE001 - the goal frame hangs on a vehicle (the van): no static answer
        pass
    by_sysid = {d.get("sysid"): d for d in tower.get("drones", [])}
    goals, vehicles = [], []
    windows: dict[int, tuple[float | None, float | None]] = {}
    for spec in sc.drones:
        res = by_sysid.get(spec.sysid, {"goals": []})
        sent = [g["sent_sim"] for g in res["goals"] if g.get("sent_sim") is not None]
        done = [g["reached_sim"] for g in res["goals"] if g.get("reached_sim") is not None]
        windows[spec.sysid] = (min(sent) if sent else None, max(done) if done else res.get("end_sim"))
        for g in res["goals"]:
            world = g.get("world")
            if world is None and static_world is not None:
                world = [float(v) for v in static_world.apply_point(np.array(g["goal"], float))]
            goals.append({"drone": spec.name, "index": g["index"], "of": len(res["goals"]),
                          "tower": list(g["goal"]), "world": world, "reached": bool(g.get("reached")),
                          "time_to_reach": g.get("time_to_reach"), "sent_sim": g.get("sent_sim"),
                          "latest_offset": g.get("latest_offset"), "sends": g.get("sends"),
                          "error": g.get("error")})
    pairs = {r: d for d, r in sc.pairs}
    names = {s: n for n, s, _k in sc.vehicles}
    # paths, heights and the separation are the flight's: up to the tower's end (sim), not
    # whatever the world ran on (free of the tower, on the wall clock) until it was stopped
    ends = [d.get("end_sim") for d in tower.get("drones", []) if d.get("end_sim") is not None]
    t_end = max(ends) if ends else None
    flown = {s: (tr.window(None, t_end) if tr is not None and t_end is not None and len(tr) else tr)
             for s, tr in tracks.items()}
    for name, sysid, kind in sc.vehicles:
        tr = flown.get(sysid)
        row: dict[str, Any] = {"name": name, "sysid": sysid, "kind": kind,
                               "path_m": _path_len(tr) if tr is not None else None,
                               "max_height_m": max(0.0, float(-(tr.xyz[:, 2] - tr.xyz[0, 2]).min()))
                               if tr is not None and len(tr) else None}
        if kind == "copter":
            mine = [g for g in goals if g["drone"] == name]
            ttr = [g["time_to_reach"] for g in mine if g["time_to_reach"] is not None]
            row.update(role=f"drone, layer {next(d.altitude for d in sc.drones if d.sysid == sysid):g} m",
                       goals_reached=sum(g["reached"] for g in mine), goals_total=len(mine),
                       mean_time_to_reach=float(np.mean(ttr)) if ttr else None)
        elif sysid in pairs:
            d = pairs[sysid]
            row["role"] = f"follows {names[d]}"
            dt = tracks.get(d)
            if tr is not None and dt is not None and len(tr) and len(dt):
                t0, t1 = windows.get(d, (None, None))
                w = tr.window(t0, t1)
                w = Track(w.t[(w.t >= dt.t[0]) & (w.t <= dt.t[-1])], w.xyz[(w.t >= dt.t[0]) & (w.t <= dt.t[-1])])
                if len(w):
                    e = horizontal_error(w.xyz, dt.at(w.t))
                    row.update(follow_rms=rms(e), follow_max=float(e.max()), follow_n=int(e.size))
        elif sc.van is not None and sysid == sc.van.sysid:
            row["role"] = f"van, carries the tower, {sc.van.speed:g} m/s route"
        vehicles.append(row)
    drone_tracks = {d.name: flown[d.sysid] for d in sc.drones if flown.get(d.sysid) is not None}
    sep = {"source": source, "minimum_m": sc.min_separation, **closest_approach(drone_tracks),
           "tower_watch": tower.get("separation")}
    reached = sum(g["reached"] for g in goals)
    offsets = [g["latest_offset"] for g in goals if g["latest_offset"] is not None]
    out = {"ok": bool(tower.get("ok")) and reached == len(goals) and reached > 0,
           "scenario": sc.name, "goals_reached": reached, "goals_total": len(goals), "source": source,
           "vehicles": vehicles, "goals": goals, "separation": sep,
           "van": ({"name": sc.van.name, "route": [list(p) for p in sc.van.route], "speed": sc.van.speed,
                    "latest_offset_max": max(offsets) if offsets else None,
                    "latest_offset_mean": float(np.mean(offsets)) if offsets else None}
                   if sc.van is not None else None),
           "bridge_status": data.bridge_status, "tower_error": tower.get("error")}
    out.update({k: v for k, v in (meta or {}).items() if k not in out})
    return out


def _f(x, spec=".2f", none="-"):
    return none if x is None else format(x, spec)


BIG_FAMILY = 12     # more drones than this: a row per layer and only the drones that missed


def _layer_rows(s: dict) -> list[str]:
    """A big family in a few lines: per altitude layer, drones, goals reached and times."""
    layers: dict[str, list[dict]] = {}
    for v in s.get("vehicles", []):
        if v["kind"] == "copter":
            layers.setdefault(v.get("role", ""), []).append(v)
    lines = [f"  {'layer':<20} {'drones':>6} {'goals':>9} {'mean reach s':>12} {'top m':>6}"]
    for role, vs in sorted(layers.items()):
        got = sum(v["goals_reached"] for v in vs)
        total = sum(v["goals_total"] for v in vs)
        ttr = [v["mean_time_to_reach"] for v in vs if v.get("mean_time_to_reach") is not None]
        top = [v["max_height_m"] for v in vs if v.get("max_height_m") is not None]
        lines.append(f"  {role:<20} {len(vs):>6} {f'{got}/{total}':>9} "
                     f"{_f(float(np.mean(ttr)) if ttr else None, '12.2f'):>12} {_f(max(top) if top else None, '6.1f'):>6}")
    missed = [v["name"] for v in s.get("vehicles", []) if v["kind"] == "copter"
              and v["goals_reached"] < v["goals_total"]]
    lines.append(f"  drones that missed a goal: {', '.join(missed) if missed else 'none'}"
                 " (every row and goal: summary.json)")
    return lines


def format_family_summary(s: dict) -> str:
    """The text of a family / van summary (a big family: per layer, see BIG_FAMILY)."""
    lines = [f"{'MISSION OK' if s.get('ok') else 'MISSION FAILED'}: {s.get('goals_reached', 0)}/"
             f"{s.get('goals_total', 0)} goals reached  |  scenario {s.get('scenario')}"
             + (f", seed {s['seed']}" if s.get("seed") is not None else "")
             + (f", speedup {s['speedup']:g}x" if isinstance(s.get("speedup"), (int, float))
                else f", speedup {s['speedup']}" if s.get("speedup") else "")
             + (f" (achieved {s['achieved_speedup']:.1f}x)" if s.get("achieved_speedup") else ""), ""]
    big = sum(1 for v in s.get("vehicles", []) if v["kind"] == "copter") > BIG_FAMILY
    if big:
        lines += _layer_rows(s)
    else:
        lines += _vehicle_rows(s)
    _separation_rows(s, lines)
    return "\n".join(lines)


def _vehicle_rows(s: dict) -> list[str]:
    lines = []
    lines.append(f"  {'vehicle':<8} {'sysid':>5}  {'role':<36} {'path m':>7} {'top m':>6}  "
                 f"{'goals':>5} {'reach s':>7}  {'follow RMS':>10} {'max':>6}")
    for v in s.get("vehicles", []):
        goals = f"{v['goals_reached']}/{v['goals_total']}" if "goals_total" in v else "-"
        lines.append(f"  {v['name']:<8} {v['sysid']:>5}  {v.get('role', ''):<36} {_f(v['path_m'], '7.1f'):>7} "
                     f"{_f(v['max_height_m'], '6.1f'):>6}  {goals:>5} {_f(v.get('mean_time_to_reach'), '7.2f'):>7}  "
                     f"{_f(v.get('follow_rms'), '10.2f'):>10} {_f(v.get('follow_max'), '6.2f'):>6}")
    moving = s.get("van") is not None
    lines += ["", f"  {'drone':<8} {'goal':>5}  {'tower [x, y]':>18}  {'world [x, y]':>16}  {'reach s':>7}"
              + ("  latest-tf m" if moving else "")]
    for g in s.get("goals", []):
        tw = f"[{g['tower'][0]:8.2f}, {g['tower'][1]:7.2f}]"
        wd = f"[{g['world'][0]:6.2f}, {g['world'][1]:6.2f}]" if g.get("world") else "-"
        reach = _f(g["time_to_reach"], "7.2f") if g["reached"] else "MISSED"
        lines.append(f"  {g['drone']:<8} {g['index']:>2}/{g['of']:<2}  {tw:>18}  {wd:>16}  {reach:>7}"
                     + (f"  {_f(g.get('latest_offset'), '11.2f'):>11}" if moving else ""))
    return lines


def _separation_rows(s: dict, lines: list[str]) -> None:
    sep = s.get("separation") or {}
    lines.append("")
    if sep.get("closest_m") is not None:
        lines.append(f"separation: closest approach of two airborne drones {sep['closest_m']:.2f} m "
                     f"({' and '.join(sep['pair'])} at t={sep['t']:.2f} s, {sep['source']}); "
                     f"minimum {sep['minimum_m']:g} m")
    elif len([v for v in s.get("vehicles", []) if v["kind"] == "copter"]) > 1:
        lines.append("separation: not measured (no two drones airborne together in the records)")
    van = s.get("van")
    if van:
        lines.append(f"time travel: each goal was resolved in world at its stamp (the van drove "
                     f"{van['speed']:g} m/s); resolved with the latest transform when reached it would "
                     f"have landed {_f(van['latest_offset_mean'])} m away on average, "
                     f"{_f(van['latest_offset_max'])} m at most")
    if s.get("tower_error"):
        lines.append(f"tower: {s['tower_error']}")
