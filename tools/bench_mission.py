"""AUTO mission speed: a 1 km, 10-waypoint copter mission flown by the in-process world,
against the sum of its legs' minimum (rest-to-rest, jerk-limited) times.

The mission: NAV_TAKEOFF to 10 m, then 10 waypoints at 10 m whose legs (from the takeoff
point through WP1..WP10) add up to 1000 m, turning 90 degrees left and right. Flight time is
sim time from the first waypoint's start ("Mission: 2 WP") to the last waypoint's
MISSION_ITEM_REACHED. The peer is tools.run_summary.minimum_time per leg with the copter's
limits (WPNAV_SPEED, WPNAV_ACCEL, PSC_JERK_XY): the time an ideal shaper needs to go from rest
to rest over each leg. ArduCopter's waypoint navigation blends corners instead of stopping,
so a ratio below 1 is possible; towerlink's stops at each waypoint's radius.
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from tools.benchtable import machine, table
from tools.run_summary import minimum_time
from vehicle.autopilot import modes
from vehicle.autopilot.mission_store import MISSION, MissionItem
from vehicle.world import World, WorldConfig

LEGS_M = (60, 140, 80, 120, 100, 90, 110, 70, 130, 100)     # 1000 m in all
ALT = 10.0


def waypoints(legs=LEGS_M) -> list[np.ndarray]:
    """North/east of the waypoints from the takeoff point (0, 0), turning +-90 deg each leg."""
    pts, p, heading = [], np.zeros(2), 0.0
    for k, d in enumerate(legs):
        p = p + d * np.array([math.cos(heading), math.sin(heading)])
        pts.append(p.copy())
        heading += math.pi / 2 if k % 2 == 0 else -math.pi / 2
    return pts


def fly(legs=LEGS_M) -> dict:
    """Fly the mission in-process; times in sim seconds, wall_s in wall seconds."""
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None))
    ap = w.vehicles[0].ap
    texts: list[tuple[float, str]] = []
    reached: list[tuple[float, int]] = []
    ap.outbox.subscribe(text=lambda sev, msg: texts.append((w.t, msg)),
                        item_reached=lambda seq: reached.append((w.t, seq)))

    def at(n, e, cmd=mav.MAV_CMD_NAV_WAYPOINT, alt=ALT):
        lat, lon, _ = geo.ned_to_lla(w.cfg.home, [n, e, 0.0])
        return MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, x=int(round(lat * 1e7)),
                           y=int(round(lon * 1e7)), z=alt)

    wps = waypoints(legs)
    ap.missions.replace_all(MISSION, [at(0, 0, alt=0.0), at(0, 0, mav.MAV_CMD_NAV_TAKEOFF)]
                            + [at(p[0], p[1]) for p in wps])
    end = w.steps + int(30 / w.dt)
    while (ap.home is None or not ap.prearm_ok()) and w.steps < end:
        w.step()
    assert ap.set_mode(modes.GUIDED) and ap.arm() == mav.MAV_RESULT_ACCEPTED
    assert ap.command(mav.MAV_CMD_MISSION_START, [0] * 7) == mav.MAV_RESULT_ACCEPTED
    wall0 = time.perf_counter()
    last = len(wps) + 1
    end = w.steps + int(900 / w.dt)
    while not any(s == last for _, s in reached) and w.steps < end:
        w.step()
    wall = time.perf_counter() - wall0
    t_start = next(t for t, m in texts if m == "Mission: 2 WP")
    t_end = next(t for t, s in reached if s == last)
    p = ap.params
    v, a, j = p["WPNAV_SPEED"] / 100.0, p["WPNAV_ACCEL"] / 100.0, p["PSC_JERK_XY"]
    legs = [float(np.linalg.norm(wps[0]))] + [float(np.linalg.norm(wps[k] - wps[k - 1])) for k in range(1, len(wps))]
    tmins = [minimum_time(d, v, a, j) for d in legs]
    return {"flight_s": t_end - t_start, "min_s": sum(tmins), "legs_m": sum(legs), "v": v, "a": a, "j": j,
            "radius_m": p["WPNAV_RADIUS"] / 100.0, "wall_s": wall, "reached": [s for _, s in reached]}


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(prog="bench_mission", description=__doc__.split("\n\n")[0]).parse_args(argv)
    r = fly()
    print(machine())
    print(table(f"1 km, 10-waypoint AUTO mission (v {r['v']:g} m/s, a {r['a']:g} m/s², j {r['j']:g} m/s³, "
                f"WPNAV_RADIUS {r['radius_m']:g} m)",
                ["", "time (s)", "ratio"],
                [["towerlink AUTO flight", f"{r['flight_s']:.1f}", f"{r['flight_s'] / r['min_s']:.3f}"],
                 ["sum of legs' minimum times", f"{r['min_s']:.1f}", "1.000"]]))
    print(f"legs {r['legs_m']:.0f} m; simulated in {r['wall_s']:.1f} s wall "
          f"({r['flight_s'] / max(r['wall_s'], 1e-9):.0f}x real time for the legs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
