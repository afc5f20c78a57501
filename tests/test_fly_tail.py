"""fly holds the stop until the truth just past the tower's end is recorded (tools/fly_launch.py
Launch._record_past_the_end): the summary's figure at the last goal reads the first sample after
it, which must not depend on how fast the processes were stopped."""
from __future__ import annotations

import json
from types import SimpleNamespace

from tools.fly_launch import TAIL_SIM_S, Launch
from tools.fly_run_folder import tower_end_sim


def test_tower_end_sim_reads_a_lab_and_a_family_result(tmp_path):
    assert tower_end_sim(tmp_path) is None                                   # no result yet
    (tmp_path / "tower.json").write_text("{not json")
    assert tower_end_sim(tmp_path) is None
    (tmp_path / "tower.json").write_text(json.dumps({"ok": True, "end_sim": 55.0}))
    assert tower_end_sim(tmp_path) == 55.0
    (tmp_path / "tower.json").write_text(json.dumps({"drones": [{"end_sim": 80.5}, {"end_sim": None},
                                                                {"end_sim": 91.25}]}))
    assert tower_end_sim(tmp_path) == 91.25
    (tmp_path / "tower.json").write_text(json.dumps({"ok": False, "end_sim": None}))
    assert tower_end_sim(tmp_path) is None


class _Clock:
    """A monitor whose sim time moves 0.05 s each time it is read; the times it gave."""

    def __init__(self, t: float) -> None:
        self.t, self.seen = t, []

    def sim_time(self) -> float:
        self.seen.append(self.t)
        self.t += 0.05
        return self.seen[-1]


def _launch(tmp_path, monitor, world_exit=None):
    return SimpleNamespace(dir=tmp_path, monitor=monitor,
                           processes=SimpleNamespace(exited=lambda name: world_exit if name == "sitl" else None))


def test_the_stop_waits_for_the_sim_time_past_the_towers_end(tmp_path):
    (tmp_path / "tower.json").write_text(json.dumps({"ok": True, "end_sim": 55.0}))
    clock = _Clock(54.9)
    Launch._record_past_the_end(_launch(tmp_path, clock))
    until = 55.0 + TAIL_SIM_S
    assert clock.seen[-1] >= until and all(t < until for t in clock.seen[:-1]) and len(clock.seen) > 4


def test_no_wait_without_a_result_or_once_the_world_has_gone(tmp_path):
    clock = _Clock(0.0)
    Launch._record_past_the_end(_launch(tmp_path, clock))                    # no tower.json
    assert clock.seen == []
    (tmp_path / "tower.json").write_text(json.dumps({"ok": True, "end_sim": 55.0}))
    Launch._record_past_the_end(_launch(tmp_path, clock, world_exit=0))       # the world exited
    assert len(clock.seen) == 1
    stuck = SimpleNamespace(sim_time=lambda: 10.0)                           # a world that stands still
    Launch._record_past_the_end(_launch(tmp_path, stuck), limit=0.05)        # returns at the wall limit
