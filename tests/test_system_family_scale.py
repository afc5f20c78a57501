"""Issue 14 on the full system: the tower's family at scale (common.family_plan's lanes and layers).

The whole system in lockstep at --speedup max (world, bridge and the family's one tower link
as participants) flies a generated family of 100 drones: every drone in its own lane, two
altitude layers, one goal each (`towerlink fly family100` flies two; `towerlink bench family`
times it). About 35-40 s wall on this 2-core machine at load average 3-4.
"""
from __future__ import annotations

import json

import pytest

from system_support import launched

pytestmark = pytest.mark.slow

DRONES = 100


def test_generated_family_every_drone_reaches_its_goal_and_separation_holds(tmp_path):
    from common.family_plan import LanePlan, scenario_toml
    from tools.family_summary import closest_approach
    from tools.run_data import RunData, load_messages, read_tlog
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
    # truth: every drone's SIM_STATE as the world sent it (vehicles.tlog alone; the bridge's
    # tlog adds nothing to this figure and takes as long again to read)
    data = RunData()
    load_messages(read_tlog(tmp_path / "vehicles.tlog"), data)
    assert sorted(data.truth) == list(range(1, DRONES + 1))
    sep = closest_approach({f"drone{k}": tr for k, tr in data.truth.items()})
    assert plan.min_separation <= sep["closest_m"] < 4.5, sep
    # the layers took off one at a time, the highest first (every drone of the upper layer
    # held its height before the first of the lower layer armed)
    up = [d for j, d in enumerate(tower["drones"]) if plan.layer(j) == plan.layers - 1]
    low = [d for j, d in enumerate(tower["drones"]) if plan.layer(j) == 0]
    assert max(d["takeoff_sim"] for d in up) <= min(d["start_sim"] for d in low)
