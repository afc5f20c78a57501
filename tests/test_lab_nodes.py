"""The reference solution (examples/lab) through `towerlink lab check`: full marks, and what its flights show.

One check of examples/lab (two flights at once, in lockstep at --speedup max): checkpoint 0 on
fly.launch; cp1, the three nodes with fly.launch's transform and the rover on drone_yaw
(checkpoints 1 and 3); cp2, the rover on the tilting drone frame (checkpoint 2). The nodes run
as separate programs (common.tf2_ros) and the bridge only routes (--route-only). The nodes take
part in the lockstep through the bridge, so cp1 flown again at --speedup 2 beside a CPU burner
gives the same figures.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from common.tf2_ros.node import component_for
from system_support import figures
from tools.lab.checker import check
from tools.lab.evidence import Evidence
from tools.lab.flights import LAB_GOALS_WORLD, Flight, FlightRun, fly
from tools.run_data import read_tlog

pytestmark = pytest.mark.slow
LAB = Path(__file__).resolve().parent.parent / "examples" / "lab"


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return check(LAB, out=tmp_path_factory.mktemp("lab_check"))


def cp(rep, n):
    return next(c for c in rep["checkpoints"] if c["number"] == n)


def test_the_reference_gets_full_marks(report):
    assert report["passed"], [(c["number"], c["measured"], c["hints"]) for c in report["checkpoints"]]
    assert [c["verdict"] for c in report["checkpoints"]] == ["PASS"] * 4
    assert all(c["hints"] == [] for c in report["checkpoints"])
    assert cp(report, 1)["figures"]["reached"] == [True, True, True]
    assert cp(report, 3)["figures"]["follow_rms_m"] < 1.0                    # the lab's mark
    assert cp(report, 3)["figures"]["wobble_rms_m"] < 1e-3                   # the level frame: no swing
    c2 = cp(report, 2)["figures"]
    assert c2["wobble_rms_m"] > 0.3 and c2["goal_swing_m"] > 0.5 * c2["wobble_rms_m"]   # it wobbles
    assert abs(cp(report, 2)["figures"]["stamp_offset_s"]) < 0.05           # on the drone's clock
    assert set(report["flights"]) == {"cp1", "cp2", "cp3"}                  # cp3 is cp1's flight
    assert report["flights"]["cp3"]["dir"] == report["flights"]["cp1"]["dir"]
    out = Path(report["report_dir"])
    assert {"report.md", "report.json", "tracks.png", "tracks-cp2.png"} <= {p.name for p in out.iterdir()}
    print(f"\nlab check of examples/lab: {report['wall_s']:.1f} s wall; flights "
          + ", ".join(f"{k} {f['sim_s']:.1f} s sim in {f['wall_s']:.1f} s" for k, f in report["flights"].items()))


def test_the_bridge_only_routed_and_the_nodes_joined_the_lockstep(report):
    run = Path(report["flights"]["cp1"]["dir"])
    log = (run / "bridge.log").read_text()
    assert "--route-only" in log.splitlines()[0] and "--lockstep-nodes 3" in log.splitlines()[0]
    node = f"node:255/{component_for('world_to_drone')}"
    assert f"node frames: drone by {node}, drone_yaw by {node}; refused 0" in log
    assert "follow ticks drone:0;" in log            # the bridge drove no follow
    assert "node lockstep: 3 node(s) in" in log
    kinds = {m.get_type() for m in read_tlog(run / "bridge.tlog")}
    assert "TOWERLINK_FOLLOW_STATUS" not in kinds and "TOWERLINK_TRANSFORM" in kinds
    said = (run / "node-tower_to_map.log").read_text()
    for x, y in LAB_GOALS_WORLD:                     # each tower goal became the lab's world goal
        assert f"Publishing Transformed Goal [{x}, {y}]" in said


def test_view_frames_shows_the_nodes_frames_with_their_rates(report):
    from tools.view_frames import buffer_from_tlog
    buf, _now = buffer_from_tlog(Path(report["flights"]["cp1"]["dir"]) / "bridge.tlog")
    st = buf.edge_stats()
    for f in ("drone", "drone_yaw"):
        assert st[f].parent == "world" and not st[f].is_static
        assert st[f].rate_hz == pytest.approx(20.0, rel=0.1)      # the drone's telemetry rate
    assert st["tower"].is_static


def test_the_same_flight_at_2x_beside_a_cpu_burner_gives_the_same_figures(report, tmp_path):
    nodes = tuple(LAB / f"{n}.py" for n in ("tower_to_map", "world_to_drone", "ground_robot_controller"))
    flight = Flight("cp1", "drone_yaw", cp(report, 0)["figures"]["args"], nodes, "cp1 again at 2x")
    ev_max = Evidence.read(FlightRun(flight, Path(report["flights"]["cp1"]["dir"])))
    burner = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        run = fly(flight, tmp_path / "cp1_2x", speedup=2.0)
    finally:
        burner.kill()
        burner.wait(5)
    ev_2x = Evidence.read(run)
    a, b = figures(ev_max.summary), figures(ev_2x.summary)
    assert len(a) > 40 and "follow_error.rms" in a
    diff = {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
    assert diff == {}, f"figures that differ between max and 2x (loaded): {diff}"
