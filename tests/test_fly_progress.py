"""What `towerlink fly` prints while a run flies (tools.fly_progress): the progress line, which
lines are printed, the tower's goal state and the achieved speedup. Pure, with a fake clock;
one test runs Launch.wait against a stand-in tower process."""
from __future__ import annotations

import io
import sys

import pytest

from tools.fly_progress import (WAITING, GoalState, ProgressReporter, SpeedupMeter, TowerOutput, goal_text,
                                progress_line)


class Clock:
    """A wall clock the test moves."""

    def __init__(self, t: float = 100.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


FLYING = {"sim": 12.5, "drone": (1.0, -2.0, -9.0), "follow_err": 0.42}


def test_the_line_says_asked_max_at_max_speed_and_nx_otherwise():
    line = progress_line(WAITING, "goal -/- (preparing)", None, float("inf"), True)
    assert "(asked max, lockstep)" in line and "maxx" not in line
    assert line.startswith("[fly] t=   0.00 s sim  goal -/- (preparing)")
    assert "drone [waiting]" in line and "speedup - " in line
    line = progress_line(FLYING, "goal 2/4 sent", 6.54, 5.0, False)
    assert line.endswith("speedup 6.5x (asked 5x)")
    assert "drone [   1.00,   -2.00,  -9.00]" in line and "rover err  0.42 m" in line
    assert "(asked 0.5x, lockstep)" in progress_line(FLYING, "g", None, 0.5, True)


def test_a_world_still_starting_says_it_is_waiting_once():
    clock = Clock()
    r = ProgressReporter(float("inf"), True, every=1.0, clock=clock)
    printed = []
    for _ in range(3):                          # three seconds of nothing moving
        printed.append(r.line(WAITING, "goal -/- (preparing)", None))
        clock.t += 1.0
    assert [p is not None for p in printed] == [True, False, False]
    assert "drone [waiting]" in printed[0]
    # the sim clock moves: a line again, but not before a second has passed since the last look
    assert r.line(FLYING, "goal 1/4 sent", 6.0) is not None
    clock.t += 0.5
    assert r.line({**FLYING, "sim": 15.0}, "goal 1/4 sent", 6.0) is None
    clock.t += 0.5
    assert r.line({**FLYING, "sim": 15.0}, "goal 1/4 sent", 6.0) is not None
    # the same state with only the measured speedup changed (a stalled world) is not news
    clock.t += 1.0
    assert r.line({**FLYING, "sim": 15.0}, "goal 1/4 sent", 5.0) is None
    # a new goal state is, at the same sim time
    clock.t += 1.0
    assert "goal 1/4 reached" in r.line({**FLYING, "sim": 15.0}, "goal 1/4 reached", 5.0)


def test_no_progress_lines_when_quiet():
    r = ProgressReporter(5.0, False, every=None, clock=Clock())
    assert not r.due()
    assert r.line(WAITING, "goal -/- (preparing)", None) is None


def test_a_line_is_due_when_one_may_be_printed():
    """Launch.wait takes the poses (a snapshot) only when a line is due."""
    clock = Clock()
    r = ProgressReporter(5.0, True, every=1.0, clock=clock)
    assert r.due()
    assert r.line(FLYING, "goal 1/4 sent", 5.0) is not None
    assert not r.due()
    clock.t += 0.99
    assert not r.due() and r.line({**FLYING, "sim": 20.0}, "goal 1/4 sent", 5.0) is None
    clock.t += 0.01
    assert r.due() and r.line({**FLYING, "sim": 20.0}, "goal 1/4 sent", 5.0) is not None


def test_launch_wait_prints_one_waiting_line_for_a_world_that_never_moves(tmp_path):
    from tools.fly_launch import Launch
    launch = Launch(tmp_path, speedup=float("inf"), lockstep=True)
    launch.processes.start("tower", [sys.executable, "-c", "import time; time.sleep(1.0)"], on_line=launch.tower.feed)
    out = io.StringIO()
    try:
        rc = launch.wait(10, progress=0.1, out=out)
    finally:
        launch.stop()
    assert rc == 0
    lines = out.getvalue().splitlines()
    assert len(lines) == 1, lines
    assert "drone [waiting]" in lines[0] and "(asked max, lockstep)" in lines[0]


def test_the_tower_output_gives_the_goal_state_and_the_sent_goals():
    tower = TowerOutput()
    assert tower.feed("tower: takeoff: 9 m reached at t=7.30 s (tower [-128.55, 77.05, -8.50])") is None
    assert tower.goals == GoalState()
    sent = tower.feed("tower: goal 1/4 sent: tower [-131.04, 73.52, -9.00] at t=7.30 s")
    assert sent == (7.30, (-131.04, 73.52, -9.0))
    assert (tower.goals.n, tower.goals.total, tower.goals.last, tower.goals.count) == (1, 4, "sent", 0)
    assert tower.feed("tower: goal 1/4 reached: tower [-131.04, 73.52, -9.00] in 2.96 s sim "
                      "(at t=10.26 s, 0.48 m off, 3 sends, 0.3 s wall)") is None
    assert (tower.goals.reached, tower.goals.last, tower.goals.count) == (1, "reached", 1)
    assert tower.feed("tower: goal 2/4 sent: tower [1, 2] at t=10.26 s") == (10.26, (1.0, 2.0, 0.0))
    tower.feed("tower: goal 2/4 FAILED: timed out")
    assert (tower.goals.n, tower.goals.last, tower.goals.reached) == (2, "FAILED", 1)
    assert len(tower.lines) == 5
    assert goal_text(tower.goals) == "goal 2/4 FAILED"
    assert goal_text(GoalState()) == "goal -/- (preparing)"
    assert goal_text(tower.goals, family_goals=12) == "goals 1/12 reached"


def test_the_speedup_is_measured_from_when_the_sim_clock_first_moves():
    clock = Clock()
    meter = SpeedupMeter(clock)
    assert meter.update(0.0) is None and meter.overall(0.0) is None     # the world not started
    clock.t += 5.0
    assert meter.update(2.0) is None                                    # anchored here
    clock.t += 0.25
    assert meter.update(3.0) is None                                    # too soon to tell
    clock.t += 1.75
    assert meter.update(12.0) == pytest.approx(5.0)                     # 10 s sim in 2 s wall
    assert meter.overall(12.0) == pytest.approx(5.0)
