"""Plot a run's tracks: drone, rover, goals and the tower, plus follow error and wobble over time.

  towerlink plot runs/20240101-120000            # writes runs/.../tracks.png
  towerlink plot vehicles.tlog -o tracks.png     # any tlog with the vehicles' telemetry

The map is north up, east right (world NED seen from above). Tracks are truth
(SIM_STATE) when the tlog has it, the vehicles' own estimate (LOCAL_POSITION_NED)
otherwise. Goals come from the run's tower.json (converted to world with the
scenario's frames); the tower, usually far outside the flown area, is shown in an
overview inset and by an arrow at the map's edge. The right-hand panel shows the
rover's distance to the drone's ground point and the attitude-caused ground-point
error of both drone frames (when the bridge's follow ticks were recorded).

A family or van run draws every vehicle the scenario lists (drones solid, following
rovers dashed, the van dotted), every drone's goals numbered with its name, and one
follow-error curve per (drone, rover) pair.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from tools.run_data import DRONE, ROVER, RunData, load_messages, load_run, read_tlog


def _goals_world(run_dir: Path | None, scenario: str | None):
    from common.scenario import load_scenario
    meta = {}
    if run_dir is not None and (run_dir / "meta.json").exists():
        meta = json.loads((run_dir / "meta.json").read_text())
    sc = load_scenario(scenario or meta.get("scenario"))
    buf = sc.buffer()
    tower_origin = None
    if "tower" in sc.frames() and buf.can_transform("world", "tower"):   # not when it rides the van
        tower_origin = buf.lookup_transform("world", "tower").transform.translation
    goals = []
    if run_dir is not None and (run_dir / "tower.json").exists():
        tj = json.loads((run_dir / "tower.json").read_text())
        for d in tj.get("drones", []):           # a family: every drone's goals, labelled
            for g in d.get("goals", []):
                w = g.get("world")
                if w is None and buf.can_transform("world", g.get("frame", "tower")):
                    w = buf.lookup_transform("world", g.get("frame", "tower")).transform.apply_point(
                        np.array(g["goal"], float))
                if w is not None:
                    goals.append((np.array(w, float), bool(g.get("reached")), f"{d['name']} {g['index']}"))
        for g in tj.get("goals", []):
            T = buf.lookup_transform("world", g.get("frame", "tower")).transform
            goals.append((T.apply_point(np.array(g["goal"], float)), bool(g.get("reached"))))
    elif buf.can_transform("world", sc.goal_frame):
        T = buf.lookup_transform("world", sc.goal_frame).transform
        goals = [(T.apply_point(np.array(g, float)), None, f"{d.name} {k + 1}" if sc.is_family else None)
                 for d in sc.drones for k, g in enumerate(d.goals)]
    return goals, tower_origin, buf, sc


LAB_VEHICLES = ((DRONE, "drone", "copter"), (ROVER, "rover", "rover"))


def plot(data: RunData, out: str | Path, *, goals=(), tower=None, buf=None, title: str = "",
         vehicles=LAB_VEHICLES, pairs=((DRONE, ROVER),), van: int | None = None, spoke=()) -> Path:
    """vehicles: (sysid, name, kind) to draw; pairs: (drone, rover) sysids whose follow error
    is plotted; van: the sysid drawn dotted; spoke: (van xy, goal xy) world pairs, where the
    tower on the van was when it sent each goal, drawn as a triangle and a thin line."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(15, 6.5), dpi=100)
    ax = fig.add_axes([0.05, 0.09, 0.42, 0.8])
    src = "truth" if data.truth else "estimate"
    tracks = data.truth or data.estimate
    pts = []
    lab = tuple(vehicles) == LAB_VEHICLES
    palette = ["tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
               "tab:pink", "tab:olive", "tab:cyan", "tab:gray"]
    colors = {sysid: palette[k % len(palette)] for k, (sysid, _n, _kind) in enumerate(vehicles)}
    # a rover takes its drone's colour, lighter: pairs read at a glance
    for d, r in pairs:
        if not lab and d in colors and r in colors:
            colors[r] = colors[d]
    for sysid, name, kind in vehicles:
        tr = tracks.get(sysid)
        if tr is None or not len(tr):
            continue
        color = colors[sysid]
        ls = ":" if sysid == van else ("-" if kind == "copter" else "--")
        ax.plot(tr.xyz[:, 1], tr.xyz[:, 0], color=color if sysid != van else "black",
                lw=1.6 if kind == "copter" else 1.2, label=f"{name} ({src})", ls=ls,
                alpha=1.0 if kind == "copter" or lab else 0.7)
        ax.plot(tr.xyz[0, 1], tr.xyz[0, 0], "o", color=color if sysid != van else "black", ms=5)
        pts.append(tr.xyz[:, :2])
    for k, item in enumerate(goals):
        g, reached = item[0], item[1]
        label = item[2] if len(item) > 2 and item[2] else f"{k + 1}"
        mk = "*" if reached in (True, None) else "x"
        ax.plot(g[1], g[0], mk, color="green" if reached in (True, None) else "red", ms=14,
                label="goals" if k == 0 else None)
        ax.annotate(label, (g[1], g[0]), textcoords="offset points", xytext=(7, 7), fontsize=10 if lab else 8)
        pts.append(np.array([g[:2]]))
    for k, (pv, pg) in enumerate(spoke):
        ax.plot(pv[1], pv[0], "^", color="purple", ms=9, label="tower (on the van) when it sent the goal" if k == 0 else None)
        ax.plot([pv[1], pg[1]], [pv[0], pg[0]], color="purple", lw=0.8, ls="-", alpha=0.6)
        pts.append(np.array([pv[:2]]))
    ax.plot(0, 0, "k+", ms=10, label="world origin (home)")
    pts.append(np.zeros((1, 2)))
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0) - 5, allp.max(axis=0) + 5
    ax.set_xlim(lo[1], hi[1])
    ax.set_ylim(lo[0], hi[0])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("east, world y (m)")
    ax.set_ylabel("north, world x (m)")
    ax.grid(alpha=0.3)
    if tower is not None:
        tx, ty = float(tower[0]), float(tower[1])
        inside = lo[0] <= tx <= hi[0] and lo[1] <= ty <= hi[1]
        if inside:
            ax.plot(ty, tx, "^", color="purple", ms=12, label="tower")
        else:
            c = (lo + hi) / 2
            d = np.array([tx, ty]) - c
            dist = float(np.hypot(*(np.array([tx, ty]))))
            # arrow from inside the map towards the tower
            half = (hi - lo) / 2 * 0.85
            s = min(half[0] / max(abs(d[0]), 1e-9), half[1] / max(abs(d[1]), 1e-9))
            tip = c + d * s
            ax.annotate(f"tower at world [{tx:.1f}, {ty:.1f}]\n{dist:.0f} m from home",
                        xy=(tip[1], tip[0]), xytext=(c[1] + d[1] * s * 0.55, c[0] + d[0] * s * 0.55),
                        arrowprops=dict(arrowstyle="->", color="purple"), color="purple", fontsize=9,
                        ha="center")
            ins = fig.add_axes([0.5, 0.5, 0.16, 0.36])
            for tr, color in ((tracks.get(DRONE), "tab:blue"),):
                if tr is not None and len(tr):
                    ins.plot(tr.xyz[:, 1], tr.xyz[:, 0], color=color, lw=1)
            ins.plot(ty, tx, "^", color="purple", ms=7)
            ins.plot(0, 0, "k+")
            if buf is not None and buf.can_transform("world", "tower"):  # the tower's axes, 25 m long
                T = buf.lookup_transform("world", "tower").transform
                for axis, col in ((np.array([25.0, 0, 0]), "red"), (np.array([0, 25.0, 0]), "green")):
                    e = T.apply_point(axis)
                    ins.plot([ty, e[1]], [tx, e[0]], color=col, lw=1)
            ins.set_aspect("equal", adjustable="datalim")
            ins.set_title("overview (tower x red, y green)", fontsize=7)
            ins.tick_params(labelsize=6)
    ax.legend(loc="center" if lab else "best", fontsize=8 if lab else 7)
    ax.set_title(title or "tracks (world, seen from above)", fontsize=11)

    ax2 = fig.add_axes([0.71, 0.56, 0.26, 0.33])
    ax3 = fig.add_axes([0.71, 0.09, 0.26, 0.33], sharex=ax2)
    names = {s: n for s, n, _k in vehicles}
    for d, r in pairs:
        dr, rv = data.truth.get(d), data.truth.get(r)
        if dr is not None and rv is not None and len(dr) and len(rv):
            m = (rv.t >= dr.t[0]) & (rv.t <= dr.t[-1])
            err = np.hypot(*(rv.xyz[m, :2] - dr.at(rv.t[m])[:, :2]).T)
            label = "rover to drone ground point (truth)" if lab else \
                f"{names.get(r, r)} to {names.get(d, d)} ground point (truth)"
            ax2.plot(rv.t[m], err, color="tab:orange" if lab else colors[d], lw=1, label=label)
    if data.follow:
        f = data.follow
        ax3.plot(f["t"], f["err_full"], color="tab:red", lw=1, label="full attitude (drone)")
        ax3.plot(f["t"], f["err_yaw"], color="tab:green", lw=1.2, label="yaw-only (drone_yaw)")
        ax3b = ax3.twinx()
        ax3b.plot(f["t"], np.degrees(f["tilt"]), color="gray", lw=0.6, alpha=0.6)
        ax3b.set_ylabel("tilt (deg)", color="gray", fontsize=8)
        ax3b.tick_params(labelsize=7, colors="gray")
    ax2.set_ylabel("follow error (m)")
    ax2.grid(alpha=0.3)
    if ax2.get_legend_handles_labels()[0]:
        ax2.legend(fontsize=8, loc="upper right")
    ax2.set_title("rover follow and wobble over sim time", fontsize=10)
    ax3.set_ylabel("attitude-caused\nground-point error (m)", fontsize=9)
    ax3.set_xlabel("sim time (s)")
    ax3.grid(alpha=0.3)
    if data.follow:
        ax3.legend(fontsize=8, loc="upper right")
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out


def plot_run(path: str | Path, out: str | Path | None = None, scenario: str | None = None,
             data: RunData | None = None) -> Path:
    """Plot a run folder or a single tlog (`data`: the run folder's, already loaded); returns
    the PNG written."""
    path = Path(path)
    if path.is_dir():
        data = data if data is not None else load_run(path)
        run_dir = path
        out = out or path / "tracks.png"
        title = f"tracks: {path.name}"
    else:
        data = load_messages(read_tlog(path))
        run_dir = path.parent if (path.parent / "tower.json").exists() else None
        out = out or path.with_suffix(".png")
        title = f"tracks: {path.name}"
    goals, tower, buf, sc = _goals_world(run_dir, scenario)
    if not sc.is_family:
        return plot(data, out, goals=goals, tower=tower, buf=buf, title=title)
    vehicles = [(s, n, k) for n, s, k in sc.vehicles]
    spoke = []
    vt = (data.truth or data.estimate).get(sc.van.sysid) if sc.van else None
    if vt is not None and len(vt) and run_dir is not None and (run_dir / "tower.json").exists():
        for d in json.loads((run_dir / "tower.json").read_text()).get("drones", []):
            spoke += [(vt.at(g["sent_sim"]), g["world"]) for g in d.get("goals", [])
                      if g.get("sent_sim") is not None and g.get("world") is not None]
    return plot(data, out, goals=goals, tower=tower, buf=buf, title=title, vehicles=vehicles,
                pairs=sc.pairs, van=sc.van.sysid if sc.van else None, spoke=spoke)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("path", help="a run folder (written by towerlink fly) or a tlog")
    parser.add_argument("-o", "--output", default=None, help="PNG to write (default: tracks.png in the run)")
    parser.add_argument("--scenario", default=None, help="scenario for goals/tower (default: the run's)")


def run(args: argparse.Namespace) -> int:
    p = Path(args.path)
    if not p.exists():
        print(f"towerlink plot: {p}: no such run folder or tlog")
        return 2
    out = plot_run(p, args.output, args.scenario)
    print(f"wrote {out}")
    return 0
