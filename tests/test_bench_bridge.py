"""Smoke run of the bridge benchmark (a few seconds): the table has its rows, the bridge
process really forwarded goals and telemetry, and `towerlink bench bridge` knows it.

The figures themselves are not asserted (speed targets live in the benchmark's own
report, not in a timed unit test)."""
from __future__ import annotations

import importlib
import re

from tools import bench, bench_bridge


def _row(out: str, label: str) -> list[str]:
    lines = [l for l in out.splitlines() if l.startswith(label)]
    assert len(lines) == 1, (label, out)
    return re.split(r"\s{2,}", lines[0][len(label):].strip())


def _number(cell: str) -> float:
    return float(re.match(r"[\d,.]+", cell).group(0).replace(",", ""))


def test_bench_bridge_smoke(capsys):
    status = bench_bridge.main(["--quick", "--samples", "50", "--seconds", "0.3", "--vehicles", "1", "10", "100",
                                "--no-peer"])
    out = capsys.readouterr().out
    assert status == 0, out
    assert "cores | Python" in out.splitlines()[0]                 # the machine line
    assert "bridge pinned to CPU" in out and "load average" in out
    header = [l for l in out.splitlines() if l.startswith("measure")][0].split()
    assert header == ["measure", "towerlink", "peer", "peer", "figure", "ratio", "target", "status"]
    for q in (50, 99):
        through, peer, direct, ratio = _row(out, f"goal tower -> drone socket, p{q}")
        assert peer == "direct UDP link, same datagrams"
        assert _number(through) > 0 and _number(direct) > 0 and ratio.endswith("x")
    added = _row(out, "  added by the bridge, p99")
    assert added[1] == "<= 1 ms" and added[2] in ("met", "MISSED")
    assert _number(_row(out, "  bridge runnable but waiting for its CPU, mean per goal")[0]) >= 0
    # every goal went through the bridge and came back translated (none lost)
    assert _row(out, "  samples (lost: bridge, direct)") == ["50 (0)", "50 (0)"]
    for n, label in ((1, "vehicle"), (10, "vehicles"), (100, "vehicles")):
        cells = _row(out, f"forwarded msg/s, telemetry from {n} {label}")
        assert _number(cells[0]) > 0, f"nothing forwarded with {n} vehicles"
        assert cells[-2] == ">= 20,000 /s" and cells[-1] in ("met", "MISSED")
    per_cpu = [re.split(r"\s{2,}", l.strip()) for l in out.splitlines()
               if l.startswith("  forwarded per CPU-second of the bridge")]
    assert len(per_cpu) == 3
    for cells in per_cpu:
        assert _number(cells[1]) > 0 and cells[-2:] in ([">= 20,000", "met"], [">= 20,000", "MISSED"]), cells


def test_bench_bridge_peer_is_mavproxy_fed_the_same_traffic(capsys):
    status = bench_bridge.main(["--quick", "--samples", "20", "--seconds", "0.5", "--vehicles", "10"])
    out = capsys.readouterr().out
    assert status == 0, out
    cells = _row(out, "forwarded msg/s, telemetry from 10 vehicles")
    assert cells[1] == "MAVProxy router, same CPU", cells
    assert _number(cells[2]) > 0 and "cores" in cells[2], "MAVProxy forwarded nothing"
    assert cells[3].endswith("x")


def test_bench_bridge_is_registered():
    assert bench.BENCHES["bridge"] == "tools.bench_bridge"
    assert importlib.import_module(bench.BENCHES["bridge"]).main is bench_bridge.main
