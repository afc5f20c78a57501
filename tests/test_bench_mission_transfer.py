"""Smoke run of `towerlink bench mission-transfer` (small: 10 items, once): both clients complete
their transfers against a real sitl and the table has a ratio for each; no speed is asserted
(speed targets live in the benchmark's report, not in tests)."""
from __future__ import annotations

import re

import pytest

from tools import bench_mission_transfer


@pytest.mark.timeout(120)
def test_bench_runs_and_reports_both_clients(capsys):
    assert bench_mission_transfer.main(["--items", "10", "--repeat", "1"]) == 0
    out = capsys.readouterr().out
    assert "cores" in out                                    # the machine line
    for row in ("upload 10 items", "download 10 items"):
        line = next(l for l in out.splitlines() if l.startswith(row))
        ms_py, ms_sdk, ratio = (float(v) for v in re.findall(r"[\d.]+", line[len(row):]))
        assert ms_py > 0 and ms_sdk > 0 and ratio == pytest.approx(ms_sdk / ms_py, rel=0.5, abs=0.05)
