"""Issue 11 on the full system: with --lockstep a seed gives the same figures at any speed and load.

Two `towerlink fly --lockstep` runs of one mission (seed 1; world, bridge and tower as
processes on loopback): one at --speedup 2 with a CPU-burning process beside it (the
machine's other work), one at --speedup max. Every number in summary.json must be equal,
except the fields that describe the machine or the launch rather than the flight
(system_support.WALL_FIELDS).
"""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from system_support import MISSION_WORLD, figures, finish, launched, tower_goals

pytestmark = pytest.mark.slow


def fly(run_dir, speedup: float) -> dict:
    with launched(run_dir, goals=tower_goals(MISSION_WORLD), follow_frame="drone_yaw", finish="land",
                  speedup=speedup, lockstep=True) as launch:
        finish(launch, timeout=240)         # asserts the tower finished its goals
    return json.loads((run_dir / "summary.json").read_text())


def test_same_figures_at_2x_under_load_and_at_max(tmp_path):
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        slow = fly(tmp_path / "x2_loaded", 2.0)
    finally:
        burner.kill()
        burner.wait(5)
    fast = fly(tmp_path / "max", float("inf"))
    assert slow["ok"] and fast["ok"]
    assert slow["limits_assumed"] == fast["limits_assumed"] == []     # the limits were read from the drone
    assert slow["speedup"] == 2.0 and fast["speedup"] == "max"
    a, b = figures(slow), figures(fast)
    assert len(a) > 40 and "follow_error.rms" in a and "goals[2].time_to_reach" in a
    diff = {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
    assert diff == {}, f"figures that differ between 2x (loaded) and max: {diff}"
