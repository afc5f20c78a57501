"""Benchmark: the tower's family of 100 drones, end to end.

`towerlink fly family100` in whole-system lockstep at --speedup max (lockstep period 0.1 s
sim): the world (100 drones, one process: lockstep refuses --workers), the bridge with 100
vehicle links and the tower flying all of them on one link. Reports the wall time of the
flight, the sim time flown and so the achieved speedup, every goal reached or not, the
closest approach of two airborne drones (truth, SIM_STATE) against min_separation, the CPU
each process used, and the machine's load average.

Peer: none measured side by side. ArduPilot needs a process per drone (100 SITL copters
would not run on these 2 cores), and a family tower with one link per drone (as the tower
once had) would need more links than the bridge's peer table (64) holds. The figure to
compare with is real time: a ratio of 1.0 is a GCS keeping up with 100 drones.

  python -m tools.bench_family [--drones N] [--legs K]
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path


def _cpu_s(pid: int) -> float | None:
    """CPU seconds (user + system) a process used so far, from /proc."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return None


def fly_family(run_dir: Path, drones: int, legs: int, period: float = 0.1, timeout: float = 300.0) -> dict:
    """Fly a generated family once; the figures as a dict."""
    from common.family_plan import LanePlan, scenario_toml
    from tools.family_summary import summarize_family
    from tools.fly_launch import Launch
    plan = LanePlan(drones=drones, legs=legs)
    path = run_dir / f"family{drones}.toml"
    path.write_text(scenario_toml(plan))
    launch = Launch(run_dir, scenario=str(path), speedup=float("inf"), lockstep=True, finish="none",
                    seed=1, sitl_args=("--lockstep-period", f"{period:g}"))
    cpu: dict[str, float | None] = {}
    t0 = time.monotonic()
    try:
        launch.start()
        rc = launch.wait(timeout, progress=None)
        wall = time.monotonic() - t0
        # the tower has exited (its CPU is gone with it); the others are still up
        cpu = {n: _cpu_s(p.pid) for n, p in launch.procs.items() if n != "tower"}
    finally:
        launch.stop()
    s = summarize_family(run_dir, scenario_path=str(path))
    sims = [g["sent_sim"] + g["time_to_reach"] for g in s["goals"] if g["time_to_reach"] is not None]
    sim = max(sims) if sims else 0.0
    return {"drones": drones, "rc": rc, "wall_s": wall, "sim_s": sim, "ratio": sim / wall if wall else 0.0,
            "goals": f"{s['goals_reached']}/{s['goals_total']}", "closest_m": s["separation"]["closest_m"],
            "min_separation": plan.min_separation, "cpu_s": cpu, "load": os.getloadavg()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tools.bench_family", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--drones", type=int, default=100)
    p.add_argument("--legs", type=int, default=2, help="goals per drone (default 2, as family100.toml)")
    a = p.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench_family_") as d:
        r = fly_family(Path(d), a.drones, a.legs)
    cpu = ", ".join(f"{n} {v:.1f} s" for n, v in r["cpu_s"].items() if v is not None)
    print(f"family of {r['drones']} drones, lockstep --speedup max, {a.legs} goal(s) each "
          f"(machine: {os.cpu_count()} cores, load average {r['load'][0]:.2f} {r['load'][1]:.2f} {r['load'][2]:.2f})")
    print(f"  goals reached           {r['goals']}  (tower exit {r['rc']})")
    print(f"  flight                  {r['sim_s']:.1f} s sim in {r['wall_s']:.1f} s wall from launch: "
          f"{r['ratio']:.2f}x real time (peer: real time, 1.00x)")
    closest = "-" if r["closest_m"] is None else f"{r['closest_m']:.2f} m"
    print(f"  closest approach        {closest} (truth), minimum {r['min_separation']:g} m")
    print(f"  CPU                     {cpu} (tower not counted: it has exited)")
    return 0 if r["rc"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
