"""The plugin's lockstep mode: a gcs.client script gives the same numbers at any speed and load.

The example script (examples/pytest/test_tower_client_lockstep.py: GUIDED, arm, take off,
a goal, land) runs twice on the fixture's world in lockstep: at speedup 8 with a process
burning a core beside it, and at max. Every sim time it reports and the vehicle's final truth
must be equal to the last bit.
"""
from __future__ import annotations

import dataclasses
import importlib.util
import subprocess
import sys

import pytest

from plugin_support import ROOT
from tools.sitl_fixture import TowerlinkSitl
from tools.sitl_spec import make_spec

pytestmark = pytest.mark.slow       # two flights of ~45 s sim, one at 8x: too long for the fast pass


def example():
    path = ROOT / "examples/pytest/test_tower_client_lockstep.py"
    spec = importlib.util.spec_from_file_location("tower_client_lockstep_example", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def fly(tmp_path, speedup) -> dict:
    sitl = TowerlinkSitl(make_spec({"lockstep": True, "speedup": speedup}), tmp_path / f"x{speedup}").start()
    try:
        out = example().mission(sitl.client(0))
        out["reached"] = dataclasses.astuple(out["reached"].position)
        out["truth"] = dataclasses.asdict(sitl.vehicle(0))
        out["sim_time"] = sitl.time
        return out
    finally:
        sitl.stop()


def test_lockstep_client_flight_is_identical_at_8x_under_load_and_at_max(tmp_path):
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        slow = fly(tmp_path, 8)
    finally:
        burner.kill()
        burner.wait(5)
    fast = fly(tmp_path, "max")
    assert slow["truth"]["landed"] and slow["at_goal"] > slow["took_off"] > 1.0
    assert slow == fast
