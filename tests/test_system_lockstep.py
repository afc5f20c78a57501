"""Issue 11 on the full system: with --lockstep a seed gives the same figures at any speed and load.

Two `towerlink fly --lockstep` runs of one mission (seed 1; world, bridge and tower as
processes on loopback): one at --speedup 4 with a CPU-burning process beside it (the
machine's other work), one at --speedup max. Every number in summary.json must be equal,
except the fields that describe the machine or the launch rather than the flight
(system_support.WALL_FIELDS).

The run at max is also MAVLink 2 signed end to end (`towerlink fly --signing-key`: world,
bridge with --vehicle-signing, tower): nothing is refused anywhere, the figures are the
unsigned run's, and the key is nowhere in the run folder.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from system_support import MISSION_WORLD, PACED, assert_paced, figures, finish, launched, tower_goals

pytestmark = pytest.mark.slow


SECRET = "lockstep run passphrase"


def fly(run_dir, speedup: float, signing_key: str | None = None) -> dict:
    with launched(run_dir, goals=tower_goals(MISSION_WORLD), follow_frame="drone_yaw", finish="land",
                  speedup=speedup, lockstep=True, signing_key=signing_key) as launch:
        finish(launch, timeout=240)         # asserts the tower finished its goals
    return json.loads((run_dir / "summary.json").read_text())


def test_same_figures_at_4x_under_load_and_at_max(tmp_path):
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        slow = fly(tmp_path / "x4_loaded", PACED)
    finally:
        burner.kill()
        burner.wait(5)
    fast = fly(tmp_path / "max", float("inf"), signing_key=SECRET)
    assert slow["ok"] and fast["ok"]
    assert fast["signed"] and not slow["signed"]
    assert_signed_throughout(tmp_path / "max")
    assert slow["limits_assumed"] == fast["limits_assumed"] == []     # the limits were read from the drone
    assert_paced(slow, PACED)
    assert fast["speedup"] == "max"
    a, b = figures(slow), figures(fast)
    assert len(a) > 40 and "follow_error.rms" in a and "goals[2].time_to_reach" in a
    diff = {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
    assert diff == {}, f"figures that differ between 4x (loaded) and max: {diff}"


def assert_signed_throughout(run: Path) -> None:
    """Every process ran with the key, refused nothing, and no file holds the key in clear."""
    logs = {n: (run / f"{n}.log").read_text() for n in ("sitl", "bridge", "tower")}
    for name, text in logs.items():                 # each command line, as logged: masked
        assert "--signing-key '***'" in text.splitlines()[0], name
    assert "--vehicle-signing" in logs["bridge"].splitlines()[0]
    assert "tower: signing: 0 packet(s) refused" in logs["tower"]
    counters = [ln for ln in logs["bridge"].splitlines() if " bad signature " in ln]
    assert {ln.split(":")[0] for ln in counters} >= {"tower", "drone", "rover"}
    assert all(ln.endswith("unsigned 0 bad signature 0") for ln in counters), counters
    assert "unsigned" not in logs["sitl"] and "bad_signature" not in logs["sitl"]
    assert "lockstep: tower (sysid 255, compid 190) joined" in logs["sitl"]
    from common.mavlink.signing import key_from_text
    key = key_from_text(SECRET)
    forms = (SECRET.encode(), key, key.hex().encode())      # the passphrase, the key, its hex
    assert [p.name for p in run.iterdir() if p.is_file() and any(f in p.read_bytes() for f in forms)] == []
