"""The lab flight's figures do not move when the world's step gets faster.

tests/data/lab_summary/seed{1,2,3}.json are the summaries `towerlink fly --seed N --speedup max`
wrote with the previous release (ca7883d), before the in-process stepping was sped up, with the
figures a documented change moved since (a numerics change, or the pipelined lockstep's one
period of latency: tests/data/lab_summary/CHANGES.md). In
lockstep a seed fixes every figure, so the same flight now must give the same figures:
strings, flags and integers exactly, floats within 1e-9 relative (+1e-9 absolute) -- the
speed-ups keep every operation's order, so they agree to the bit today; the tolerance only
leaves room for a last-bit difference of a math library. Wall-clock fields (how fast and
where it ran, system_support.WALL_FIELDS) are not compared, and figures added to the
summary since are not in the baselines.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from system_support import figures

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data" / "lab_summary"
REL = ABS = 1e-9


def differences(old: dict, new: dict) -> list[str]:
    """The baseline's figures that `new` lacks or gives differently (see the module doc)."""
    out = []
    for k, want in old.items():
        if k not in new:
            out.append(f"{k}: missing (was {want!r})")
            continue
        got = new[k]
        if isinstance(want, float) and isinstance(got, (int, float)) and not isinstance(got, bool):
            if not math.isclose(got, want, rel_tol=REL, abs_tol=ABS):
                out.append(f"{k}: {got!r} != {want!r} (off by {got - want:.3g})")
        elif got != want:
            out.append(f"{k}: {got!r} != {want!r}")
    return out


def test_differences_finds_a_moved_figure():
    old = {"a": 1.0, "b": "x", "c": 3}
    assert differences(old, {"a": 1.0 + 1e-12, "b": "x", "c": 3, "new": 5}) == []
    assert len(differences(old, {"a": 1.001, "b": "y"})) == 3


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_lab_flight_figures_equal_the_previous_release(seed, tmp_path):
    out = tmp_path / "run"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-m", "tools.cli", "fly", "--seed", str(seed), "--speedup", "max",
                        "--out", str(out), "-q"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    old = figures(json.loads((DATA / f"seed{seed}.json").read_text()))
    new = figures(json.loads((out / "summary.json").read_text()))
    assert differences(old, new) == []
