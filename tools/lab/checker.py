"""`towerlink lab check` for one student: which flights, their verdicts, the report.

Checkpoint 0 needs no flight. The others are judged on flights (tools.lab.flights), chosen so
each checkpoint judges the student's own part of the lab:

* cp1  the student's three nodes with fly.launch's static transform, the rover on drone_yaw:
       checkpoint 1 (and checkpoint 3 too, when checkpoint 1 passed: it is then the lab's full
       system flying the level frame);
* cp2  the lab's tower transform and the reference tower_to_map (examples/lab) driving the drone,
       the student's world_to_drone and ground_robot_controller, the rover on drone: checkpoint 2;
* cp3  as cp2 with the rover on drone_yaw, for checkpoint 3 when cp1 cannot stand for it.

A checkpoint whose files are still the skeletons is "not done yet" without a flight. The
flights that are needed fly at once (each is a few processes in lockstep at --speedup max).
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from tools.lab import cp0 as cp0_mod
from tools.lab import cp1 as cp1_mod
from tools.lab import cp_follow
from tools.lab.evidence import Evidence
from tools.lab.flights import Flight, FlightRun, fly
from tools.lab.result import Checkpoint
from tools.lab.submission import NODES, Submission

ALL = (0, 1, 2, 3)
REFERENCE = Path(__file__).resolve().parents[2] / "examples" / "lab"


def reference_node(name: str) -> Path | None:
    """The reference solution's node (examples/lab), when this checkout has it."""
    p = REFERENCE / f"{name}.py"
    return p if p.exists() else None


def _flights(sub: Submission, asked: set[int], pre: dict[int, Checkpoint | None]) -> dict[str, Flight]:
    student = {n: sub.path(n) for n in NODES}
    truth = cp0_mod.Args.of(cp0_mod.truth()).text()
    t2m = reference_node("tower_to_map") or student["tower_to_map"]
    helper = "the reference tower_to_map" if t2m != student["tower_to_map"] else "your tower_to_map"
    out: dict[str, Flight] = {}
    if 1 in asked and pre[1] is None:
        out["cp1"] = Flight("cp1", "drone_yaw", sub.launch.args, tuple(student.values()),
                            "your three nodes and fly.launch's static transform; the rover follows drone_yaw")
    for n, frame in ((2, "drone"), (3, "drone_yaw")):
        if n in asked and pre[n] is None:
            out[f"cp{n}"] = Flight(f"cp{n}", frame, truth,
                                   (t2m, student["world_to_drone"], student["ground_robot_controller"]),
                                   f"the lab's tower transform and {helper} fly the drone; your world_to_drone "
                                   f"and ground_robot_controller drive the rover through {frame}")
    return out


def check(folder: str | Path, asked=ALL, out: str | Path | None = None, plot: bool = True) -> dict:
    """Check one student's folder; writes the report into `out` (default FOLDER/lab-check) and
    returns it as a dict (report.json)."""
    t0 = time.monotonic()
    sub = Submission.read(folder)
    asked = set(asked)
    out = Path(out) if out else sub.dir / "lab-check"
    out.mkdir(parents=True, exist_ok=True)
    cp0 = cp0_mod.judge(sub.launch)
    pre: dict[int, Checkpoint | None] = {1: cp1_mod.precheck(sub, cp0) if 1 in asked else None,
                                         2: cp_follow.precheck(sub, 2) if 2 in asked else None,
                                         3: cp_follow.precheck(sub, 3) if 3 in asked else None}
    flights = _flights(sub, asked, pre)
    if "cp1" in flights and "cp3" in flights and cp0.passed:
        # cp1's flight flies the lab's goals (the transform is right): it stands for checkpoint 3
        # too if it passes checkpoint 1; cp3 flies only if it does not
        del flights["cp3"]
    runs = _fly_all(flights, out / "runs")
    evidence = {k: Evidence.read(r) for k, r in runs.items()}
    results: dict[int, Checkpoint] = {0: cp0}
    if 1 in asked:
        results[1] = pre[1] or cp1_mod.judge(sub, evidence["cp1"])
    if 3 in asked and pre[3] is None and "cp3" not in evidence:
        if results.get(1) is not None and results[1].passed:
            evidence["cp3"] = evidence["cp1"]
        else:                                   # cp1's flight did not fly the lab's goals: fly cp3 now
            f = _flights(sub, {3}, {3: None})
            runs.update(_fly_all(f, out / "runs"))
            evidence["cp3"] = Evidence.read(runs["cp3"])
    for n in (2, 3):
        if n in asked:
            results[n] = pre[n] or cp_follow.judge(sub, evidence[f"cp{n}"], n)
    from tools.lab.report import write_report
    return write_report(sub, {n: results[n] for n in sorted(asked)}, evidence, out,
                        wall=time.monotonic() - t0, plot=plot)


def _fly_all(flights: dict[str, Flight], runs_dir: Path) -> dict[str, FlightRun]:
    if not flights:
        return {}
    # imported here, once, before the threads: two threads importing one module at once may see it half made
    from common.mavlink.dialect import towerlink  # noqa: F401
    import tools.fly_launch  # noqa: F401
    import tools.fly_monitor  # noqa: F401
    with ThreadPoolExecutor(max_workers=len(flights)) as pool:
        futures = {k: pool.submit(fly, f, runs_dir / k) for k, f in flights.items()}
        return {k: fut.result() for k, fut in futures.items()}
