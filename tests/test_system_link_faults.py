"""Faults as code on the full system: a scenario's fault timeline flown in lockstep.

The lab's short mission over a lossy, slow, jittery, narrow tower link (10 % loss, 0.2 s
latency, reordering, duplicates, 12 kB/s down: below the telemetry's rate, so the
queue fills and drops), with a battery sag on the drone at t = 2 s and
a 2 s outage of the tower link at t = 14 s, and a 3 s GPS glitch on the drone at t = 6 s (SIM_GPS1_GLTCH_X:
5.6 m north: "GPS Glitch" without an EKF failsafe). The mission still completes, and the
summary says which failsafe the sag caused and when. Flown twice, at --speedup 4 beside a CPU-burning
process and at --speedup max: every figure of the two summaries is equal, the faults' times,
the failsafes and the link's frame counts included (system_support.WALL_FIELDS aside).
"""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from common.scenario import DEFAULT_SCENARIO
from system_support import HOUSE, PACED, assert_paced, figures, finish, launched, tower_goals
from tools.run_data import load_run

pytestmark = pytest.mark.slow

SHORT = [HOUSE, (10.0, -2.0), (10.0, 6.0)]
FAULTS = '''
[[faults]]
t = 0
target = "tower_link"
loss = 0.1
latency = 0.2
jitter = 0.05
reorder = 0.02
duplicate = 0.02
down.bandwidth = 12000

[[faults]]
t = 2
target = "drone"
SIM_BATT_VOLTAGE = 10.0

[[faults]]
t = 14
duration = 2
target = "tower_link"
loss = 1.0

[[faults]]
t = 6
until = 9
target = "drone"
SIM_GPS1_GLTCH_X = 0.00005
'''


def fly(run_dir, scenario, speedup: float) -> dict:
    with launched(run_dir, scenario=str(scenario), goals=tower_goals(SHORT), finish="land", speedup=speedup,
                  lockstep=True) as launch:
        finish(launch, timeout=240)         # asserts the tower finished its goals
    return json.loads((run_dir / "summary.json").read_text())


def test_a_fault_timeline_gives_the_same_summary_at_4x_under_load_and_at_max(tmp_path):
    scenario = tmp_path / "faults.toml"
    scenario.write_text(DEFAULT_SCENARIO.read_text() + FAULTS)
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        slow = fly(tmp_path / "x4_loaded", scenario, PACED)
    finally:
        burner.kill()
        burner.wait(5)
    fast = fly(tmp_path / "max", scenario, float("inf"))
    assert slow["ok"] and fast["ok"], slow.get("text")
    assert_paced(slow, PACED)
    f = fast["faults"]
    link, battery, outage, glitch = f["faults"]
    # the link's faults are the proxy's own, at their TICK; a vehicle's is a PARAM_SET the world applies
    # as a reaction of the tower's to that TICK: one lockstep frame (40 ms) later, the world being pipelined
    assert (link["applied"], battery["applied"], outage["applied"], outage["cleared"]) == (0.0, 2.04, 14.0, 16.0)
    assert (glitch["applied"], glitch["cleared"]) == (6.04, 9.04)
    assert glitch["failsafes"] == []                                  # a small step: no EKF failsafe,
    for run in ("x4_loaded", "max"):                                  # but the glitch check's warning
        said = [(round(t, 2), text) for t, _, text in load_run(tmp_path / run).texts[1] if "Glitch" in text]
        assert said and said[0] == (6.16, "GPS Glitch") and said[1][1] == "GPS Glitch cleared", said
    level, action = battery["failsafes"]                              # the monitor's level, the vehicle's words
    assert level["text"].startswith("Battery 1 is low") and action["text"] == "Battery Failsafe"
    assert 10.0 <= action["after"] < 10.5 and level["t"] == action["t"]    # BATT_LOW_TIMER after the sag
    assert action["mode"] == "GUIDED"                                 # BATT_FS_LOW_ACT 0: it only warns
    assert link["failsafes"] == outage["failsafes"] == []             # FS_GCS_ENABLE is 0
    p = fast["proxy"]
    assert p["dropped"]["down"] > 100 and p["dropped"]["up"] > 0 and p["duplicated"]["down"] > 0, p
    assert p["overflow"]["down"] > 100, p                          # the narrow link's queue overflowed
    assert fast["tower_link"] is None or fast["tower_link"] == slow["tower_link"]
    text = (tmp_path / "max" / "summary.txt").read_text()
    assert "-> drone: 'Battery Failsafe' at" in text and "[2] t 14 tower_link loss=1 until 16: applied 14.00" in text
    a, b = figures(slow), figures(fast)
    assert len(a) > 60 and "faults.faults[1].failsafes[1].t" in a and "proxy.dropped.down" in a
    diff = {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
    assert diff == {}, f"figures that differ between 4x (loaded) and max: {diff}"
