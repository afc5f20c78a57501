"""Checking many students at once: one row per student, the checks in parallel.

Each check is `tools.lab.checker.check` on one folder, in a process of its own: Ray tasks when
Ray is installed (the sweep extra: `pip install towerlink[sweep]`), else a local process pool.
A check that fails to run (a folder that is not a lab at all, an error in the checker) is a
row with its error, never the end of the grading.
"""
from __future__ import annotations

import importlib.util
import os
import random
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any, Callable

def cpus_per_check(asked) -> float:
    """Ray's CPU share of one check: flights are a few processes each, checkpoint 0 alone is a read."""
    return 1.0 if set(asked) - {0} else 0.25


def check_one(spec: tuple) -> dict[str, Any]:
    """`check(folder, asked, out)` that never raises: a failure is the row's error."""
    folder, asked, out, plot = spec
    random.seed()       # a forked worker has its parent's RNG: free_udp_ports would pick its sibling's ports
    try:
        from tools.lab.checker import check
        return {**check(folder, asked, out, plot=plot), "worker_pid": os.getpid()}
    except Exception as exc:  # noqa: BLE001 - one student's broken folder must not stop the class
        from tools.lab.result import TITLES
        return {"name": Path(folder).name, "dir": str(folder), "report_dir": str(out), "passed": False,
                "worker_pid": os.getpid(),
                "error": f"{type(exc).__name__}: {exc}", "wall_s": 0.0, "flights": {}, "plots": {},
                "checkpoints": [{"number": n, "title": TITLES[n], "passed": False, "verdict": "FAIL",
                                 "measured": "the check could not run", "hints": [], "notes": [str(exc)]}
                                for n in sorted(asked)]}


def report_dirs(folders: list[Path], out: Path | None) -> list[Path]:
    """Where each student's report goes: FOLDER/lab-check for one student (or --out), else
    OUT/<folder name> (names made unique)."""
    if len(folders) == 1:
        return [out or folders[0] / "lab-check"]
    root, seen, dirs = out or Path("lab-check"), {}, []
    for f in folders:
        name = f.name
        seen[name] = seen.get(name, 0) + 1
        dirs.append(root / (name if seen[name] == 1 else f"{name}-{seen[name]}"))
    return dirs


def ray_or_none(use_ray: bool | None, cpus: int):
    """Ray, started quietly, when it is installed (and not refused); None otherwise."""
    if use_ray is False:
        return None
    # only tools.sweep imports Ray (the sweep extra); here we just ask whether it is there
    if importlib.util.find_spec("ray") is None:
        if use_ray:
            raise RuntimeError("--ray: Ray is not installed (pip install 'towerlink[sweep]')")
        return None
    from tools.sweep import start_ray
    return start_ray(None, cpus)


def grade(folders: list[Path], asked, out: Path | None, jobs: int | None = None, use_ray: bool | None = None,
          plot: bool = True, on_done: Callable[[dict], None] | None = None) -> tuple[list[dict], str]:
    """Check every folder; returns (the reports in folder order, how they ran)."""
    specs = [(f, tuple(asked), d, plot) for f, d in zip(folders, report_dirs(folders, out))]
    if len(specs) == 1:
        rep = check_one(specs[0])
        if on_done:
            on_done(rep)
        return [rep], "one check"
    jobs = jobs or os.cpu_count() or 1
    ray = ray_or_none(use_ray, jobs)
    if ray is not None:
        return _on_ray(ray, specs, cpus_per_check(asked), on_done), f"Ray {ray.__version__}, {len(specs)} tasks"
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = {pool.submit(check_one, s): i for i, s in enumerate(specs)}
        reps: list = [None] * len(specs)
        for fut in as_completed(futures):
            reps[futures[fut]] = fut.result()
            if on_done:
                on_done(reps[futures[fut]])
    return reps, f"{jobs} local process(es)"


def _on_ray(ray, specs, cpus: float, on_done) -> list[dict]:
    task = ray.remote(num_cpus=cpus, max_retries=0)(check_one)
    refs = {task.remote(s): i for i, s in enumerate(specs)}
    reps: list = [None] * len(specs)
    try:
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                reps[refs[ref]] = ray.get(ref)
                if on_done:
                    on_done(reps[refs[ref]])
    finally:
        ray.shutdown()
    return reps
