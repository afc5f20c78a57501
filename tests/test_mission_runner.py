"""The mission walker (vehicle/autopilot/mission_runner.py) against AP_Mission's rules: order,
DO_JUMP repeat counts, do/condition commands beside the navigation, start / stop / resume,
set_current, and the STATUSTEXT it says. Pure: a scripted "vehicle" decides when each
command is done."""
from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_geo import ItemFrameError, item_alt_z, item_ned
from vehicle.autopilot.mission_runner import COMPLETE, RUNNING, STOPPED, MissionRunner
from vehicle.autopilot.mission_store import MissionItem

WP, JUMP = mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_CMD_DO_JUMP
COND_DELAY, SPEED = mav.MAV_CMD_CONDITION_DELAY, mav.MAV_CMD_DO_CHANGE_SPEED


def item(cmd, p1=0.0, p2=0.0, frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, x=1, y=1, z=10.0):
    return MissionItem(0, frame, cmd, param1=p1, param2=p2, x=x, y=y, z=z)


class Script:
    """A vehicle whose commands finish when the test says (`done` holds seqs verified done)."""

    def __init__(self, items, auto_done=True):
        self.items = [it.with_seq(i) for i, it in enumerate(items)]
        self.started: list[int] = []
        self.verified: list[int] = []
        self.texts: list[str] = []
        self.completed = 0
        self.auto_done = auto_done
        self.done: set[int] = set()
        self.refuse: set[int] = set()
        self.r = MissionRunner(lambda: self.items, self.start, self.verify, self.complete,
                               lambda sev, msg: self.texts.append(msg))

    def start(self, it):
        self.started.append(it.seq)
        return it.seq not in self.refuse

    def verify(self, it):
        ok = self.auto_done or it.seq in self.done
        if ok:
            self.verified.append(it.seq)
        return ok

    def complete(self):
        self.completed += 1

    def run(self, steps=200):
        for _ in range(steps):
            self.r.update()
            if self.r.state != RUNNING:
                break


HOME = item(WP)


def test_walks_nav_commands_in_order_and_completes_once():
    s = Script([HOME, item(WP), item(WP), item(WP)])
    s.r.start()
    s.run()
    assert s.started == [1, 2, 3]
    assert s.verified == [1, 2, 3]
    assert s.r.state == COMPLETE and s.completed == 1
    assert s.texts == ["Mission: 1 WP", "Mission: 2 WP", "Mission: 3 WP"]


def test_do_jump_repeats_its_count_then_falls_through():
    s = Script([HOME, item(WP), item(WP), item(JUMP, 1, 2), item(WP)])
    s.r.start()
    s.run()
    assert s.started == [1, 2, 1, 2, 1, 2, 4]
    assert "Mission: 3 Jump 1/2" in s.texts and "Mission: 3 Jump 2/2" in s.texts
    assert not any("Jump 3/" in t for t in s.texts)
    assert 3 not in s.started and 3 not in s.verified           # a jump is never started or reached
    assert s.r.state == COMPLETE


def test_do_jump_forever_keeps_looping_silently():
    s = Script([HOME, item(WP), item(WP), item(JUMP, 1, -1), item(WP)])
    s.r.start()
    s.run(steps=50)
    assert s.r.state == RUNNING
    assert s.started.count(1) >= 10 and 4 not in s.started
    assert not any("Jump" in t for t in s.texts)


@pytest.mark.parametrize("target", [0, 9, float("nan")])
def test_jump_to_an_invalid_target_ends_the_mission(target):
    s = Script([HOME, item(WP), item(JUMP, target, 1), item(WP)])
    s.r.start()
    s.run()
    assert s.started == [1]
    assert s.r.state == COMPLETE


def test_a_forever_loop_of_commands_that_cannot_start_ends_the_mission():
    s = Script([HOME, item(WP), item(WP), item(JUMP, 1, -1)])
    s.refuse.update({1, 2})
    s.r.start()                                      # must return: no nav command ever starts
    assert s.r.state == COMPLETE and s.completed == 1
    assert 0 < len(s.started) <= 300


def test_jump_counts_reset_when_the_mission_starts_again():
    s = Script([HOME, item(WP), item(JUMP, 1, 1), item(WP)])
    s.r.start()
    s.run()
    assert s.started == [1, 1, 3]
    s.started.clear()
    s.r.resume()                      # COMPLETE -> starts from the top, counts fresh
    s.run()
    assert s.started == [1, 1, 3]


def test_do_commands_run_beside_the_next_nav_and_a_condition_holds_later_do_commands():
    """Do/condition items between two nav items run while the vehicle flies the second."""
    s = Script([HOME, item(WP), item(COND_DELAY, 5), item(SPEED, 1, 3), item(WP)], auto_done=False)
    s.r.start()
    s.r.update()
    assert s.started == [1]                          # nothing to do on the first leg
    s.done.add(1)
    s.r.update()
    assert s.started == [1, 2, 4]                    # the condition starts with the next leg
    for _ in range(5):
        s.r.update()
    assert 3 not in s.started                        # held back by the unfinished condition
    assert s.r.current_seq() == 4                    # the navigation is not held back
    s.done.add(2)
    s.r.update()                                     # condition verified
    s.r.update()                                     # next do command loaded
    assert s.started == [1, 2, 4, 3]
    assert s.texts[-1] == "Mission: 3 ChangeSpeed"


def test_a_nav_command_that_cannot_start_is_skipped():
    s = Script([HOME, item(WP), item(WP), item(WP)])
    s.refuse.add(2)
    s.r.start()
    s.run()
    assert s.started == [1, 2, 3]
    assert s.verified == [1, 3]


def test_resume_restarts_the_command_it_was_flying():
    s = Script([HOME, item(WP), item(WP), item(WP)], auto_done=False)
    s.r.start()
    s.done.add(1)
    s.r.update()
    assert s.r.current_seq() == 2
    s.r.stop()                                       # left AUTO
    assert s.r.state == STOPPED
    s.started.clear()
    s.r.start_or_resume(restart=False)               # MIS_RESTART 0
    assert s.r.state == RUNNING and s.started == [2] and s.r.current_seq() == 2


def test_mis_restart_starts_from_the_first_item():
    s = Script([HOME, item(WP), item(WP), item(WP)], auto_done=False)
    s.r.start()
    s.done.add(1)
    s.r.update()
    s.r.stop()
    s.started.clear()
    s.r.start_or_resume(restart=True)                # MIS_RESTART 1
    assert s.started == [1] and s.r.current_seq() == 1


def test_set_current_while_stopped_is_where_resume_begins():
    s = Script([HOME, item(WP), item(WP), item(SPEED, 1, 2), item(WP)], auto_done=False)
    assert s.r.set_current(2) is True
    assert s.r.state == STOPPED and s.r.current_seq() == 2
    assert s.started == []                           # nothing flies until AUTO resumes
    s.r.resume()
    assert s.started == [2]
    assert s.r.set_current(4) is True                # running: jumps now
    assert s.started[-1] == 4 and s.r.current_seq() == 4


@pytest.mark.parametrize("seq", [-1, 5, 99])
def test_set_current_out_of_range_is_refused(seq):
    s = Script([HOME, item(WP), item(WP), item(WP), item(WP)])
    assert s.r.set_current(seq) is False


def test_no_mission_is_not_present_and_set_current_refused():
    s = Script([HOME])
    assert not s.r.present()
    assert s.r.set_current(0) is False


def test_restart_current_nav_runs_its_start_again():
    s = Script([HOME, item(WP), item(WP)], auto_done=False)
    s.r.start()
    assert s.r.restart_current_nav() is True
    assert s.started == [1, 1]


def test_a_shorter_mission_under_a_stopped_runner_restarts_from_the_top():
    s = Script([HOME, item(WP), item(WP), item(WP)], auto_done=False)
    s.r.start()
    s.done.update({1, 2})
    s.r.update()
    s.r.update()
    assert s.r.current_seq() == 3
    s.r.stop()
    s.items = s.items[:2]                            # a new, shorter upload
    s.started.clear()
    s.r.resume()
    assert s.started == [1]


# ----- where items point -------------------------------------------------------------
ORIGIN = (47.0, 8.0, 400.0)


def test_relative_and_amsl_altitudes_and_the_zero_defaults():
    default = np.array([1.0, 2.0, -7.0])
    rel = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, x=470000000, y=80000000, z=12.0)
    amsl = MissionItem(1, mav.MAV_FRAME_GLOBAL_INT, WP, x=470000000, y=80000000, z=412.0)
    here = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, x=0, y=0, z=0.0)
    home_z = -1.0
    assert np.allclose(item_ned(rel, ORIGIN, home_z, default), [0, 0, -13.0])
    assert np.allclose(item_ned(amsl, ORIGIN, home_z, default), [0, 0, -12.0])
    assert np.allclose(item_ned(here, ORIGIN, home_z, default), default)
    north = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, x=470000000 + 8983, y=80000000, z=5.0)
    assert item_ned(north, ORIGIN, 0.0, default)[0] == pytest.approx(100.0, abs=0.05)   # 1e-7 deg = 1.11 cm
    assert item_alt_z(rel, ORIGIN, home_z) == -13.0


def test_local_ned_items_are_metres_times_1e4():
    it = MissionItem(1, mav.MAV_FRAME_LOCAL_NED, WP, x=125000, y=-30000, z=-8.0)
    assert np.allclose(item_ned(it, ORIGIN, 0.0, np.zeros(3)), [12.5, -3.0, -8.0])


@pytest.mark.parametrize("frame", [mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, mav.MAV_FRAME_BODY_NED])
def test_unflyable_frames_raise_a_typed_error(frame):
    it = MissionItem(3, frame, WP, x=470000000, y=80000000, z=5.0)
    with pytest.raises(ItemFrameError, match="item 3: frame"):
        item_ned(it, ORIGIN, 0.0, np.zeros(3))


def test_a_non_finite_altitude_is_a_typed_error():
    it = MissionItem(2, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WP, x=470000000, y=80000000, z=math.nan)
    with pytest.raises(ItemFrameError, match="not finite"):
        item_ned(it, ORIGIN, 0.0, np.zeros(3))
