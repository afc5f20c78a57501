"""Helpers for the full-system tests: one `towerlink fly` launch per test, always stopped."""
from __future__ import annotations

import contextlib
import json
import time
from pathlib import Path

from tools.fly_launch import Launch

# world [-4, -2] (the lab's house), world [26, -2] (a 30 m leg: full cruise at 5 m/s),
# world [26, 8]; as tower coordinates through the default scenario's static frame.
def tower_goals(world_xy, scenario=None) -> str:
    import numpy as np
    from common.scenario import load_scenario
    from gcs.tower_mission import format_goals
    sc = load_scenario(scenario)
    T = sc.buffer().lookup_transform("tower", "world").transform
    return format_goals([tuple(T.apply_point(np.array([x, y, -sc.altitude]))) for x, y in world_xy])


HOUSE = (-4.0, -2.0)
MISSION_WORLD = [HOUSE, (26.0, -2.0), (26.0, 8.0)]


@contextlib.contextmanager
def launched(run_dir: Path, **kw):
    """Start a Launch; yield it; stop every process whatever happens."""
    kw.setdefault("speedup", 5.0)
    kw.setdefault("seed", 1)
    kw.setdefault("goal_timeout", 60.0)
    launch = Launch(run_dir, **kw)
    try:
        launch.start()
        yield launch
    finally:
        launch.stop()


def wait_goal(launch: Launch, n: int, what: str, timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        gs = launch.goal_state
        if gs.n > n or (gs.n == n and (what == "sent" or gs.last == what)):
            return
        if launch.procs["tower"].poll() is not None:
            raise AssertionError("tower ended early:\n" + "\n".join(launch.tower_lines[-15:]))
        time.sleep(0.05)  # poll
    raise AssertionError(f"goal {n} not {what} in {timeout} s; tower said:\n" + "\n".join(launch.tower_lines[-15:]))


def finish(launch: Launch, timeout: float) -> dict:
    rc = launch.wait(timeout, progress=None)
    launch.stop()
    s = launch.finish_run(rc)
    assert rc == 0, (f"tower exit {rc}\n" + "\n".join(launch.tower_lines[-20:]) + "\n" + s["text"])
    return s


#: summary.json fields that are not flight figures: what was asked, how fast the machine
#: delivered it (wall), where it ran (ports, commands, the world's host), whether it was
#: MAVLink 2 signed (signing must not change a figure), and the bridge's
#: packet counters as of its last status message (sent once a wall second, so they count
#: whatever passed by then)
WALL_FIELDS = ("speedup", "achieved_speedup", "run_dir", "ports", "commands", "world_host", "bridge_status",
               "signed")


def flatten(d, prefix=""):
    """{"a": {"b": [1, 2]}} -> {"a.b[0]": 1, "a.b[1]": 2}"""
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else k))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            out.update(flatten(v, f"{prefix}[{i}]"))
    else:
        out[prefix] = d
    return out


def figures(summary: dict) -> dict:
    """Every number (and flag, and name) of a summary.json that describes the flight, flattened."""
    return {k: v for k, v in flatten(summary).items() if k.split(".")[0].split("[")[0] not in WALL_FIELDS
            and k != "text"}


#: the speed of the determinism tests' paced run (beside a CPU burner) of the lab's mission: well
#: below what that run achieves at max on a loaded two-core machine (about 8x), so it is held
#: to this pace rather than running free, and it differs from the free run at max
PACED = 4.0


def assert_paced(summary: dict, speedup: float) -> None:
    """The run was held to `speedup` sim s per wall s (none faster): a paced run, not a free one."""
    achieved = summary.get("achieved_speedup")
    assert summary["speedup"] == speedup and achieved is not None and achieved <= speedup * 1.05, \
        (summary["speedup"], achieved)


def tower_result(run_dir: Path) -> dict:
    return json.loads((run_dir / "tower.json").read_text())
