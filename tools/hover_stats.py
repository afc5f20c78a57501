"""Hover figures: where the drone hovers in a run, how well it holds, and the wobble there.

A hover is a stretch of truth (SIM_STATE) of at least HOVER_MIN_S seconds where the drone is
HOVER_MIN_HEIGHT m or more above its ground, its horizontal speed is under HOVER_SPEED and its
vertical speed under HOVER_VSPEED: holding a position, so a slow LAND descent (LAND_SPEED
0.5 m/s, the end of every `towerlink fly` run) counts, a WPNAV_SPEED_UP climb does not. In it:
- hover error: horizontal distance of the true position from that stretch's mean position
  (what wind and turbulence push it off by; the first SETTLE_S seconds are left out);
- wobble: the ground-point error the attitude adds through the full-attitude drone frame
  and through the yaw-only one (the bridge's follow ticks, else the recorded transforms).
  In still air a hovering drone is nearly level and both are small; in wind it leans into
  it, so the full-attitude frame's ground point sits off by about h tan(tilt) and moves
  with the gusts, while the yaw-only frame's does not.

Pure data work on tools.run_data's RunData; `python -m tools.hover_stats` also flies an
in-process hover with and without wind (vehicle.world) and prints the figures side by side.
"""
from __future__ import annotations

import argparse
import math
from typing import Any

import numpy as np

from tools.run_figures import ground_point_errors, stat

HOVER_SPEED = 0.3       # m/s, horizontal
HOVER_VSPEED = 1.0      # m/s, vertical
HOVER_MIN_S = 3.0       # s
HOVER_MIN_HEIGHT = 2.0  # m
SETTLE_S = 1.0          # s left out at the start of each hover


def hover_segments(t: np.ndarray, xyz: np.ndarray, vel: np.ndarray) -> list[tuple[float, float]]:
    """(start, end) sim times of the hovers in a truth track (t (N,), xyz/vel (N,3) NED)."""
    if len(t) == 0:
        return []
    ok = ((np.hypot(vel[:, 0], vel[:, 1]) < HOVER_SPEED) & (np.abs(vel[:, 2]) < HOVER_VSPEED)
          & (-xyz[:, 2] > HOVER_MIN_HEIGHT))
    out = []
    start = None
    for k in range(len(t) + 1):
        if k < len(t) and ok[k]:
            if start is None:
                start = k
        elif start is not None:
            if t[k - 1] - t[start] >= HOVER_MIN_S:
                out.append((float(t[start]), float(t[k - 1])))
            start = None
    return out


def _mask(ts: np.ndarray, segs, settle: float = 0.0) -> np.ndarray:
    m = np.zeros(len(ts), bool)
    for a, b in segs:
        m |= (ts >= a + settle) & (ts <= b)
    return m


def hover_figures(data, drone: int = 1, until: float | None = None) -> dict[str, Any]:
    """Hover error and wobble of `drone` (sysid) from a RunData, up to sim time `until` (s; the
    mission's end: what the recording holds after it, while the launcher stops the processes,
    lasts as long as the machine takes); {} when it never hovered."""
    tr = data.truth.get(drone)
    if tr is not None and until is not None:
        tr = tr.window(None, until)
    if tr is None or not len(tr):
        return {}
    vel = np.column_stack([tr.extra["vn"], tr.extra["ve"], tr.extra["vd"]])
    segs = hover_segments(tr.t, tr.xyz, vel)
    if not segs:
        return {}
    errs = []
    for a, b in segs:
        m = (tr.t >= a + SETTLE_S) & (tr.t <= b)
        p = tr.xyz[m]
        if len(p):
            errs.append(np.hypot(p[:, 0] - p[:, 0].mean(), p[:, 1] - p[:, 1].mean()))
    tilt = np.degrees(np.arccos(np.clip(np.cos(tr.extra["roll"]) * np.cos(tr.extra["pitch"]), -1, 1)))
    mt = _mask(tr.t, segs, SETTLE_S)
    out: dict[str, Any] = {
        "segments": [[a, b] for a, b in segs], "seconds": float(sum(b - a for a, b in segs)),
        "error": stat(np.concatenate(errs) if errs else []),
        "tilt_mean_deg": float(tilt[mt].mean()) if mt.any() else None,
    }
    f = data.follow
    if f:
        m = _mask(f["t"], segs, SETTLE_S)
        out["wobble"] = {"source": "bridge follow ticks", "drone": stat(f["err_full"][m]),
                         "drone_yaw": stat(f["err_yaw"][m])}
    else:
        wob = {}
        for child in ("drone", "drone_yaw"):
            ts, e = ground_point_errors(data.transforms.get(("world", child), []))
            if ts.size:
                wob[child] = stat(e[_mask(ts, segs, SETTLE_S)])
        if wob:
            out["wobble"] = {"source": "recorded world->drone transforms", **wob}
    return out


def format_hover(h: dict, wind: Any = None) -> list[str]:
    """The summary's hover lines."""
    wtxt = (f"wind {wind[0]:g} m/s from {wind[1]:g}°, turbulence {wind[2]:g} m/s" if wind else "no wind")
    if not h:
        return [f"hover ({wtxt}): the drone did not hover ({HOVER_MIN_S:g} s under {HOVER_SPEED:g} m/s "
                f"horizontally, {HOVER_VSPEED:g} m/s vertically, {HOVER_MIN_HEIGHT:g} m up)"]
    e = h["error"]
    lines = [f"hover ({wtxt}; {h['seconds']:.0f} s in {len(h['segments'])} hover(s), "
             f"mean tilt {h['tilt_mean_deg']:.1f}°): position error RMS {e['rms']:.3f} m, max {e['max']:.3f} m"]
    w = h.get("wobble") or {}
    d, y = w.get("drone"), w.get("drone_yaw")
    if d and d.get("n"):
        lines.append(f"  wobble in hover: full attitude (drone) RMS {d['rms']:.3f} m, max {d['max']:.3f} m"
                     + (f"; yaw-only (drone_yaw) RMS {y['rms']:.3f} m, max {y['max']:.3f} m" if y and y.get("n") else ""))
    return lines


# ----------------------------------------------------------------------------- in-process figures

def fly_hover(wind=None, seconds: float = 60.0, alt: float = 9.0, seed: int = 1) -> dict[str, float]:
    """Take off in an in-process World to alt, settle 10 s, hover `seconds`: truth figures
    (hover error from the hold point, tilt, full-attitude ground-point offset and its spread)."""
    from common.frames import euler_from_quaternion
    from common.frames.batch import ground_point
    from pymavlink.dialects.v20 import ardupilotmega as mav
    from vehicle.autopilot import modes
    from vehicle.world import World, WorldConfig
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None, wind=wind, seed=seed))
    ap = w.vehicles[0].ap
    while not (ap.est_ok and ap.home is not None):
        w.run_for(0.1)
    ap.set_mode(modes.GUIDED)
    ap.arm()
    ap.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt])
    while ap.pos[2] > -(alt - 0.2):
        w.run_for(0.1)
    w.run_for(10.0)
    hold = ap.hold_pos.copy()
    f = w.fleets[0][1]
    err, tilt, gp = [], [], []
    for _ in range(int(seconds / 0.02)):
        w.run_for(0.02)
        s = f.truth(0)
        err.append(float(np.hypot(*(s.pos[:2] - hold[:2]))))
        r, p, _ = euler_from_quaternion(s.quat)
        tilt.append(math.degrees(math.acos(max(-1.0, min(1.0, math.cos(r) * math.cos(p))))))
        g = ground_point(s.pos[None, :], s.quat[None, :], np.array([-s.pos[2]]))[0]
        gp.append(float(np.hypot(g[0] - s.pos[0], g[1] - s.pos[1])))
    err, gp = np.array(err), np.array(gp)
    return {"error_rms": float(np.sqrt(np.mean(err ** 2))), "error_max": float(err.max()),
            "tilt_mean_deg": float(np.mean(tilt)), "wobble_mean": float(gp.mean()),
            "wobble_rms": float(np.sqrt(np.mean(gp ** 2))), "wobble_max": float(gp.max()),
            "wobble_std": float(gp.std())}


def main(argv=None) -> int:
    from vehicle.physics.wind import WindParams, parse_wind
    p = argparse.ArgumentParser(prog="python -m tools.hover_stats",
                                description="In-process hover at 9 m with and without wind: hover error and the "
                                            "full-attitude frame's ground-point wobble, from truth.")
    p.add_argument("--wind", default="8,270,1", help="SPD,DIR[,TURB] (default 8,270,1)")
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--profile", type=int, default=1, choices=(0, 1, 2),
                   help="SIM_WIND_T (default 1: full speed at every height; 0 is ArduPilot's square law)")
    a = p.parse_args(argv)
    w = parse_wind(a.wind)
    wind = WindParams(**{**w.__dict__, "type": a.profile})
    print(f"{'':22} {'err RMS':>8} {'err max':>8} {'tilt':>6} {'gp mean':>8} {'gp RMS':>7} {'gp max':>7} {'gp std':>7}")
    for name, wp in (("calm", None), (f"wind {a.wind} T{a.profile}", wind)):
        r = fly_hover(wp, a.seconds, seed=a.seed)
        print(f"{name:22} {r['error_rms']:8.3f} {r['error_max']:8.3f} {r['tilt_mean_deg']:6.2f} "
              f"{r['wobble_mean']:8.3f} {r['wobble_rms']:7.3f} {r['wobble_max']:7.3f} {r['wobble_std']:7.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
