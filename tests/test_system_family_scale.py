"""Issue 14 on the full system: the tower's family at scale (gcs.family_plan's lanes and layers).

The whole system in lockstep at --speedup max (world, bridge and the family's one tower link
as participants) flies a generated family: every drone in its own lane, two altitude layers,
one goal each. 100 drones fly the same way (`towerlink fly family100 --lockstep --speedup max`,
`python -m tools.bench_family`), but take about a minute on this 2-core machine, over the
budget of a test; this one flies 24 (more than fit in one layer each, so lanes and shared
layers are what keep them apart) in about 20 s.
"""
from __future__ import annotations

import json

import pytest

from system_support import launched

pytestmark = pytest.mark.slow

DRONES = 24


def test_generated_family_every_drone_reaches_its_goal_and_separation_holds(tmp_path):
    from gcs.family_plan import LanePlan, scenario_toml
    from tools.family_summary import summarize_family
    plan = LanePlan(drones=DRONES, legs=1)
    path = tmp_path / "family.toml"
    path.write_text(scenario_toml(plan))
    with launched(tmp_path, scenario=str(path), speedup=float("inf"), lockstep=True, finish="none",
                  sitl_args=("--lockstep-period", "0.1")) as launch:
        rc = launch.wait(120, progress=None)
        launch.stop()
    tower = json.loads((tmp_path / "tower.json").read_text())
    assert rc == 0, "\n".join(launch.tower_lines[-20:])
    assert len(tower["drones"]) == DRONES
    for j, d in enumerate(tower["drones"]):
        (g,) = d["goals"]
        assert g["reached"] and g["distance"] <= plan.radius, d
        assert g["goal"][2] == -plan.altitude(j)                  # its own layer
    # the tower watched (estimates, tower frame) and so does the summary (truth): neither saw
    # two airborne drones closer than min_separation; lane neighbours are sqrt(2**2 + 3**2) apart
    watch = tower["separation"]
    assert watch["samples_below_minimum"] == 0 and watch["closest_m"] >= plan.min_separation, watch
    s = summarize_family(tmp_path, tower=tower, scenario_path=str(path))
    sep = s["separation"]
    assert sep["source"] == "truth (SIM_STATE)"
    assert plan.min_separation <= sep["closest_m"] < 4.5, sep
    assert s["ok"] and s["goals_reached"] == DRONES
    # the layers took off one at a time, the highest first (every drone of the upper layer
    # held its height before the first of the lower layer armed)
    up = [d for j, d in enumerate(tower["drones"]) if plan.layer(j) == plan.layers - 1]
    low = [d for j, d in enumerate(tower["drones"]) if plan.layer(j) == 0]
    assert max(d["takeoff_sim"] for d in up) <= min(d["start_sim"] for d in low)
