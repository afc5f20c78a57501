"""A real sweep on a local Ray: two runs through `towerlink sweep` as a user types it (slow).

The two runs differ only in the scenario's name, so with the same seed in lockstep they must give
the same figures; a second invocation finds both finished and flies nothing."""
from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
pytest.importorskip("ray", reason="towerlink sweep needs Ray: pip install -e '.[sweep]'")
pq = pytest.importorskip("pyarrow.parquet", reason="towerlink sweep needs pyarrow: pip install -e '.[sweep]'")

ROOT = Path(__file__).resolve().parent.parent
# figures of the mission itself (sim time, truth); bridge packet counts and the like are not compared
MISSION = ("follow_rms", "wobble_rms", "ratio_mean", "ratio_max", "mission_s", "goals.", "follow_error.",
           "wobble.", "flight.", "mission_window_sim.", "limits.")


def sweep(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "tools.cli", "sweep", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=240)


def test_two_runs_on_local_ray_same_seed_same_figures_and_a_rerun_resumes(tmp_path):
    out = tmp_path / "sweep"
    args = ("--set", "mission.goals=[[-131.039, 73.524]]", "--set", "finish=none", "--set", "name=twin-a,twin-b",
            "--seeds", "7", "--parallel", "2", "--timeout", "120", "--out", str(out))
    p = sweep(*args)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "2 runs of default.toml (2 to fly, 0 already finished) varying name" in p.stdout
    assert "towerlink sweep: 2 runs, 0 failed" in p.stdout

    with open(out / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["name"] for r in rows] == ["twin-a", "twin-b"]
    assert all(r["pass"] == "True" and r["seed"] == "7" and r["finish"] == "none" for r in rows)
    table = pq.read_table(out / "results.parquet").to_pylist()
    assert [r["run_id"] for r in table] == [r["run_id"] for r in rows]
    assert table[0]["seed"] == 7 and table[0]["pass"] is True and table[0]["goals.0.reached"] == 1.0

    figures = [k for k in table[0] if k.startswith(MISSION)]
    assert {"follow_rms", "wobble_rms", "goals.0.time_to_reach", "follow_error.rms"} <= set(figures)
    a, b = table
    assert a["follow_rms"] is not None and a["goals.0.time_to_reach"] > 0
    assert {k: a[k] for k in figures} == {k: b[k] for k in figures}

    stamps = {r["run_id"]: (out / "runs" / r["run_id"] / "row.json").stat().st_mtime_ns for r in rows}
    assert (out / "sweep.png").stat().st_size > 10_000 and "follow_rms" in (out / "effects.txt").read_text()

    again = sweep(*args)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "(0 to fly, 2 already finished)" in again.stdout and "Ray" not in again.stdout
    assert "2 runs (2 resumed), 0 failed" in again.stdout
    assert {rid: (out / "runs" / rid / "row.json").stat().st_mtime_ns for rid in stamps} == stamps
    with open(out / "results.csv") as f:
        assert [r["run_id"] for r in csv.DictReader(f)] == [r["run_id"] for r in rows]
