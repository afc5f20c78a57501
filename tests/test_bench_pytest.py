"""Smoke run of `towerlink bench pytest` (once each): the example flight test completes on the
fixture and on the hand-rolled subprocess peer, and the table has both figures and their
ratio; no speed is asserted here (the targets live in the benchmark's report;
tests/test_pytest_plugin.py checks the first heartbeat)."""
from __future__ import annotations

import re

import pytest

from tools import bench_pytest


@pytest.mark.timeout(180)
def test_bench_runs_both_fixtures_and_reports_ratios(capsys):
    assert bench_pytest.main(["--repeat", "1"]) == 0
    out = capsys.readouterr().out
    assert "cores" in out and "load average" in out
    for row in ("whole test, wall", "first heartbeat after the world starts"):
        line = next(l for l in out.splitlines() if l.startswith(row))
        mine, peer, ratio = (float(v) for v in re.findall(r"[\d.]+", line[len(row):]))
        assert mine > 0 and peer > 0 and ratio == pytest.approx(peer / mine, rel=0.1, abs=0.1)
