"""AUTO flown by the real fleet and autopilot in-process (sim time, no sockets): the copter's
6-item mission with a DO_JUMP, the mission's end, mode changes and MIS_RESTART, uploads while
flying, AUTO's refusals and corner cases in ArduPilot's words (disarmed without a mission,
AUTO_OPTIONS), unknown modes and the gripper, pause/continue, the rover's mission."""
from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from auto_world import Flight, hover_stick
from vehicle.autopilot import modes

C = mav
ACTIVE, NOT_STARTED, COMPLETE = mav.MISSION_STATE_ACTIVE, mav.MISSION_STATE_NOT_STARTED, mav.MISSION_STATE_COMPLETE


def six_item_mission(f: Flight):
    """TAKEOFF 10 m, WP A, WP B, DO_JUMP to A once, WP C, RTL (seq 1..6 after home)."""
    return [f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF),
            f.at(25, 0, 10), f.at(25, 25, 12),
            f.do(C.MAV_CMD_DO_JUMP, param1=2, param2=1),
            f.at(0, 25, 10),
            f.do(C.MAV_CMD_NAV_RETURN_TO_LAUNCH)]


def armed_in_guided(f: Flight) -> None:
    f.settle()
    assert f.ap.set_mode(modes.GUIDED)
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED


def test_copter_flies_the_six_item_mission_with_a_jump_and_ends_as_arducopter():
    f = Flight("copter")
    items = six_item_mission(f)
    f.upload(items)
    armed_in_guided(f)
    assert f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7) == C.MAV_RESULT_ACCEPTED
    assert f.ap.mode == modes.AUTO
    f.until(lambda: not f.ap.armed, 240, "mission flown and disarmed")
    # items reached in order, the jump taken once (a DO_JUMP is never "reached")
    assert f.reached_seqs() == [1, 2, 3, 2, 3, 5, 6]
    said = f.said()
    order = [m for m in said if m.startswith(("Mission:", "Reached"))]
    assert order == ["Mission: 1 Takeoff", "Mission: 2 WP", "Reached command #2", "Mission: 3 WP",
                     "Reached command #3", "Mission: 4 Jump 1/1", "Mission: 2 WP", "Reached command #2",
                     "Mission: 3 WP", "Reached command #3", "Mission: 5 WP", "Reached command #5",
                     "Mission: 6 RTL"]
    # each waypoint passed within WPNAV_RADIUS (2 m default) when it was reached
    radius = f.ap.params["WPNAV_RADIUS"] / 100.0
    targets = {2: f.ned(items[1]), 3: f.ned(items[2]), 5: f.ned(items[4])}
    for t, seq in f.reached:
        if seq in targets:
            d = np.linalg.norm(f.pos_at(t) - targets[seq])
            assert d <= radius + 0.05, (seq, t, d)
    # takeoff reached at 10 m above home
    t_takeoff = f.reached[0][0]
    assert f.pos_at(t_takeoff)[2] == pytest.approx(f.ap.home[2] - 10.0, abs=0.35)
    # the end, as ArduCopter: RTL lands at home, the mission completes, disarmed, still in AUTO
    assert f.ap.mode == modes.AUTO
    assert f.ap.on_ground and np.linalg.norm(f.ap.pos[:2] - f.ap.home[:2]) < 1.0
    assert f.ap.mission_current()[1] == COMPLETE
    # MISSION_CURRENT followed the legs in order: 1, 2, 3, 2, 3, 5, 6
    seqs = [s for _, _, _, s in f.track if s]
    legs = [s for k, s in enumerate(seqs) if k == 0 or s != seqs[k - 1]]
    assert legs[:7] == [1, 2, 3, 2, 3, 5, 6]


def test_a_mission_that_ends_on_a_waypoint_loiters_there_in_auto():
    f = Flight("copter")
    f.upload([f.at(0, 0, 8, C.MAV_CMD_NAV_TAKEOFF), f.at(15, 5, 8)])
    armed_in_guided(f)
    assert f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7) == C.MAV_RESULT_ACCEPTED
    f.until(lambda: f.ap.mission_current()[1] == COMPLETE, 90, "mission complete")
    f.step(5.0)
    end = f.ned(f.at(15, 5, 8))
    assert f.ap.armed and f.ap.mode == modes.AUTO
    assert np.linalg.norm(f.ap.pos - end) < 2.0 and np.linalg.norm(f.ap.vel) < 0.3


def test_mission_start_with_first_or_last_item_is_denied():
    f = Flight("copter")
    f.upload(six_item_mission(f))
    armed_in_guided(f)
    assert f.ap.command(C.MAV_CMD_MISSION_START, [2, 0, 0, 0, 0, 0, 0]) == C.MAV_RESULT_DENIED
    assert f.ap.command(C.MAV_CMD_MISSION_START, [0, 4, 0, 0, 0, 0, 0]) == C.MAV_RESULT_DENIED
    assert f.ap.mode == modes.GUIDED


def test_auto_without_a_mission_is_refused_in_arducopters_words():
    f = Flight("copter")
    armed_in_guided(f)
    assert f.ap.set_mode(modes.AUTO) is False
    assert f.said()[-1] == "Mode change to AUTO failed: init failed"
    assert f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7) == C.MAV_RESULT_FAILED
    assert f.ap.mode == modes.GUIDED
    assert f.ap.mission_current() == (0, mav.MISSION_STATE_NO_MISSION)


def test_disarmed_copter_enters_auto_without_a_mission_and_arming_says_why_not():
    """ArduCopter's set_mode passes ignore_checks = !armed to ModeAuto::init, which enters with
    a mission present OR ignore_checks; AP_Arming::mission_checks then refuses to arm in AUTO
    with no mission ("Mode requires mission"). Disarmed, the mission completes at once and
    MISSION_START after an upload flies it."""
    f = Flight("copter", params={"AUTO_OPTIONS": 1})
    f.settle()
    texts = len(f.texts)
    assert f.ap.set_mode(modes.AUTO) is True and f.ap.mode == modes.AUTO
    assert f.said()[texts:] == []                         # accepted silently
    f.step(1.0)
    assert f.ap.mission_current() == (0, mav.MISSION_STATE_NO_MISSION)
    assert f.ap.arm() == C.MAV_RESULT_FAILED and not f.ap.armed
    assert f.said()[-1] == "PreArm: Mode requires mission"
    f.upload([f.at(0, 0, 6, C.MAV_CMD_NAV_TAKEOFF), f.at(10, 0, 6)])
    assert f.ap.prearm_ok() and f.ap.arm() == C.MAV_RESULT_ACCEPTED
    assert f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7) == C.MAV_RESULT_ACCEPTED
    f.until(lambda: 2 in f.reached_seqs(), 60, "takeoff and first waypoint")


def test_armed_on_the_ground_auto_needs_a_takeoff_first():
    """ModeAuto::init: armed, landed and the first command not a takeoff -> "Auto: Missing
    Takeoff Cmd" (CRITICAL), then Copter::mode_change_failed's "init failed" (WARNING)."""
    f = Flight("copter")
    f.upload([f.at(10, 0, 10), f.at(0, 10, 10)])
    armed_in_guided(f)
    assert f.ap.set_mode(modes.AUTO) is False
    assert [(sev, m) for _, sev, m in f.texts[-2:]] == [
        (mav.MAV_SEVERITY_CRITICAL, "Auto: Missing Takeoff Cmd"),
        (mav.MAV_SEVERITY_WARNING, "Mode change to AUTO failed: init failed")]
    assert f.ap.mode == modes.GUIDED


def test_armed_in_guided_then_auto_with_auto_options_2_takes_off():
    """AUTO_OPTIONS 2 (AllowTakeOffWithoutRaisingThrottle): ModeAuto::takeoff_run auto-arms
    every cycle, so a copter armed in GUIDED and switched to AUTO takes off (the way GCS-only
    scripts start missions); without the bit it sits on the ground until DISARM_DELAY."""
    for options, flies in ((2, True), (0, False)):
        f = Flight("copter", params={"AUTO_OPTIONS": options, "DISARM_DELAY": 4})
        f.upload([f.at(0, 0, 6, C.MAV_CMD_NAV_TAKEOFF), f.at(10, 0, 6)])
        armed_in_guided(f)
        assert f.ap.set_mode(modes.AUTO)
        if flies:
            f.until(lambda: 2 in f.reached_seqs(), 60, "takeoff and first waypoint")
            assert f.ap.armed and f.reached_seqs()[:2] == [1, 2]
        else:
            f.step(3.0)
            assert f.ap.on_ground and f.ap.armed and not f.ap.auto_armed
            f.until(lambda: not f.ap.armed, 5, "auto-disarm after DISARM_DELAY")
            assert f.reached_seqs() == []


def test_unknown_modes_and_the_gripper_answered_as_arducopter():
    """A mode this build has not (AUTOTUNE 15, ACRO 1): AP_Vehicle::notify_no_such_mode's "No
    such mode N" and the change fails; DO_GRIPPER with no gripper enabled (GRIP_ENABLE 0):
    FAILED, nothing said."""
    f = Flight("copter")
    f.settle()
    for number in (15, 1, 99):
        assert f.ap.set_mode(number) is False
        assert f.said()[-1] == f"No such mode {number}"
    assert f.ap.command(C.MAV_CMD_DO_SET_MODE, [C.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15, 0, 0, 0, 0, 0]) \
        == C.MAV_RESULT_FAILED
    n = len(f.texts)
    for action in (0, 1):
        assert f.ap.command(C.MAV_CMD_DO_GRIPPER, [1, action, 0, 0, 0, 0, 0]) == C.MAV_RESULT_FAILED
    assert len(f.texts) == n


def test_disarmed_copter_enters_auto_but_arms_there_only_with_auto_options():
    f = Flight("copter")
    f.upload([f.at(0, 0, 6, C.MAV_CMD_NAV_TAKEOFF), f.at(10, 0, 6)])
    f.settle()
    assert f.ap.set_mode(modes.AUTO) is True
    assert f.ap.arm() == C.MAV_RESULT_FAILED
    assert "PreArm: Mode not armable" in f.said()
    f.ap.params.set("AUTO_OPTIONS", 3, save=False)       # AllowArming | AllowTakeOffWithoutRaisingThrottle
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED
    f.until(lambda: 2 in f.reached_seqs(), 60, "takeoff and first waypoint")


def test_armed_in_auto_without_takeoff_permission_idles_on_the_ground():
    f = Flight("copter", params={"AUTO_OPTIONS": 1, "DISARM_DELAY": 4})
    f.upload([f.at(0, 0, 6, C.MAV_CMD_NAV_TAKEOFF), f.at(10, 0, 6)])
    f.settle()
    assert f.ap.set_mode(modes.AUTO)
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED
    f.step(3.0)
    assert f.ap.on_ground and f.ap.armed              # no throttle to raise: it waits
    f.until(lambda: not f.ap.armed, 5, "auto-disarm after DISARM_DELAY")


@pytest.mark.parametrize("restart, resumes_at", [(0, 3), (1, 1)])
def test_leaving_auto_and_coming_back_follows_mis_restart(restart, resumes_at):
    f = Flight("copter", params={"MIS_RESTART": restart})
    f.upload([f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), f.at(20, 0, 10), f.at(20, 30, 10), f.at(0, 30, 10)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: f.ap.mission_current()[0] == 3, 60, "on the leg to item 3")
    f.step(2.0)
    hover_stick(f.ap)
    assert f.ap.set_mode(modes.LOITER)
    assert f.ap.mission_current() == (3, NOT_STARTED)      # ArduPilot: STOPPED reads NOT_STARTED
    f.step(2.0)
    n = len(f.texts)
    assert f.ap.set_mode(modes.AUTO)
    f.step(0.2)
    assert f.said()[n] == f"Mission: {resumes_at} {'WP' if resumes_at == 3 else 'Takeoff'}"
    assert f.ap.mission_current()[1] == ACTIVE
    if restart:
        # from the top: the takeoff is already done in the air (reached again at once), then item 2
        assert f.reached_seqs().count(1) == 2 and f.ap.mission_current()[0] == 2
    else:
        assert f.ap.mission_current()[0] == 3


def test_upload_while_flying_a_waypoint_restarts_the_command():
    f = Flight("copter")
    f.upload([f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), f.at(30, 0, 10), f.at(30, 30, 10)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: f.ap.mission_current()[0] == 2, 60, "on the leg to item 2")
    f.step(1.0)
    new = [f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), f.at(-20, 10, 10), f.at(30, 30, 10)]
    f.upload(new)
    f.step(0.2)
    assert f.said()[-2:] == ["Mission: 2 WP", "Auto mission changed, restarted command"]
    f.until(lambda: 2 in f.reached_seqs(), 60, "the new item 2")
    t = [t for t, s in f.reached if s == 2][0]
    assert np.linalg.norm(f.pos_at(t) - f.ned(new[1])) <= 2.05


def test_pause_and_continue_a_leg():
    f = Flight("copter")
    f.upload([f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), f.at(60, 0, 10)])
    armed_in_guided(f)
    # GUIDED pauses and resumes too, as ArduCopter's ModeGuided::pause()/resume() (issue 10)
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [0] + [0] * 6) == C.MAV_RESULT_ACCEPTED
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [1] + [0] * 6) == C.MAV_RESULT_ACCEPTED
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [2] + [0] * 6) == C.MAV_RESULT_DENIED
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: f.ap.mission_current()[0] == 2 and np.linalg.norm(f.ap.vel) > 3, 60, "cruising")
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [0] + [0] * 6) == C.MAV_RESULT_ACCEPTED
    assert f.ap.mission_current() == (2, ACTIVE)           # ArduPilot has no PAUSED state to report
    f.step(8.0)
    assert np.linalg.norm(f.ap.vel) < 0.3 and 2 not in f.reached_seqs()
    assert f.ap.command(C.MAV_CMD_DO_PAUSE_CONTINUE, [1] + [0] * 6) == C.MAV_RESULT_ACCEPTED
    f.until(lambda: 2 in f.reached_seqs(), 60, "continued to item 2")


def test_do_and_condition_items_in_flight():
    """CONDITION_YAW turns the copter, DO_CHANGE_SPEED slows the next leg, NAV_DELAY holds,
    an unknown command is skipped in ArduCopter's words, a hold time waits at the waypoint."""
    f = Flight("copter")
    f.upload([f.at(0, 0, 8, C.MAV_CMD_NAV_TAKEOFF),
              f.do(C.MAV_CMD_CONDITION_YAW, param1=90, param2=45, param3=1, param4=0),
              f.at(0, 0, 8, C.MAV_CMD_NAV_DELAY, param1=4),
              f.do(C.MAV_CMD_DO_CHANGE_SPEED, param1=1, param2=2.0),
              f.do(C.MAV_CMD_DO_PAUSE_CONTINUE, param1=0),
              f.at(30, 0, 8, param1=3)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: 6 in f.reached_seqs(), 120, "to the last waypoint")
    said = f.said()
    assert "Delaying 4 sec" in said
    assert f"Skipping invalid cmd #{C.MAV_CMD_DO_PAUSE_CONTINUE}" in said
    times = dict((s, t) for t, s in f.reached)
    assert times[3] - times[1] >= 4.0                       # the delay held the mission
    assert times[1] < times[2] < times[3]                   # the yaw (90 deg, cw) done during the delay
    assert times[2] - times[1] >= 90 / 45 - 0.1             # ... at CONDITION_YAW's 45 deg/s
    leg = [np.linalg.norm(v[:2]) for t, p, v, s in f.track if s == 6]
    assert max(leg) < 2.3                                   # DO_CHANGE_SPEED 2 m/s, not 5
    # the waypoint's hold time (param1 3 s) before it is reported reached
    arrive = min(t for t, p, v, s in f.track if s == 6 and np.linalg.norm(p - f.ned(f.at(30, 0, 8))) <= 2.0)
    assert times[6] - arrive >= 3.0 - 0.05


def test_rover_runs_a_mission_with_its_own_radius_and_speed():
    f = Flight("rover", params={"WP_RADIUS": 1.5, "WP_SPEED": 3.0})
    items = [f.at(-3, 20, 0), f.at(25, 20, 0), f.at(25, -5, 0)]
    f.upload(items)
    f.settle()
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED
    assert f.ap.set_mode(modes.ROVER_AUTO)
    f.until(lambda: f.ap.mission_current()[1] == COMPLETE, 120, "rover mission")
    assert f.reached_seqs() == [1, 2, 3]
    said = f.said()
    assert [m for m in said if m.startswith("Reached waypoint")] == [
        "Reached waypoint #1", "Reached waypoint #2", "Reached waypoint #3"]
    assert said[-1] == "Mission Complete"
    for (t, seq), it in zip(f.reached, items):
        d = np.linalg.norm(f.pos_at(t)[:2] - f.ned(it)[:2])
        assert d <= 1.5 + 0.05, (seq, d)
    top = max(np.linalg.norm(v[:2]) for _, _, v, _ in f.track)
    assert 2.5 < top < 3.3                                   # WP_SPEED 3 m/s, not CRUISE_SPEED 8
    f.step(5.0)
    assert np.linalg.norm(f.ap.vel[:2]) < 0.1 and f.ap.mode == modes.ROVER_AUTO   # holds


def test_rover_auto_without_a_mission_is_refused_in_ardurovers_words():
    f = Flight("rover")
    f.settle()
    assert f.ap.set_mode(modes.ROVER_AUTO) is False
    assert f.said()[-2:] == ["No Mission. Can't set AUTO.", "Flight mode change failed"]


def test_roi_circle_and_land_at_a_position():
    """DO_SET_ROI turns the copter to face the point while it flies; NAV_LOITER_TURNS circles
    once ("Mission: starting circle 1/1"); NAV_LAND at a position flies there, lands, disarms
    (the land item is not reported reached) and the mission goes back to its start, as
    ArduCopter resets it on disarm."""
    f = Flight("copter")
    roi = (0.0, 40.0)
    f.upload([f.at(0, 0, 8, C.MAV_CMD_NAV_TAKEOFF),
              f.at(*roi, 0, C.MAV_CMD_DO_SET_ROI),
              f.at(30, 0, 8),
              f.at(30, 0, 8, C.MAV_CMD_NAV_LOITER_TURNS, param1=1, param3=8),
              f.at(10, 5, 0, C.MAV_CMD_NAV_LAND)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: 3 in f.reached_seqs(), 60, "the waypoint")
    want = np.arctan2(roi[1] - f.ap.pos[1], roi[0] - f.ap.pos[0])
    assert abs((f.ap.yaw - want + np.pi) % (2 * np.pi) - np.pi) < np.radians(5)
    f.until(lambda: 4 in f.reached_seqs(), 120, "one turn")
    assert "Mission: starting circle 1/1" in f.said()
    ring = [np.linalg.norm(p[:2] - [30, 0]) for t, p, v, s in f.track if s == 4 and t > f.reached[-2][0] + 8]
    assert ring and min(ring) > 6.5 and max(ring) < 9.5
    f.until(lambda: not f.ap.armed, 90, "landed and disarmed")
    assert np.linalg.norm(f.ap.pos[:2] - [10, 5]) < 1.0
    assert 5 not in f.reached_seqs()
    f.step(0.5)
    assert f.ap.mission_current() == (1, ACTIVE)


def test_waypoint_radius_is_wpnav_radius_and_param2_is_ignored_as_arducopter():
    """ArduCopter keeps only param1 (hold time) of a NAV_WAYPOINT: a 15 m param2 does not make
    the waypoint reached early; WPNAV_RADIUS (cm) does."""
    f = Flight("copter", params={"WPNAV_RADIUS": 500})
    assert f.ap.auto.mission.wp_radius() == 5.0
    wp = f.at(40, 0, 10, param2=15.0)
    f.upload([f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), wp, f.at(40, 40, 10)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: 2 in f.reached_seqs(), 60, "the waypoint")
    t = [t for t, s in f.reached if s == 2][0]
    d = np.linalg.norm(f.pos_at(t) - f.ned(wp))
    assert 4.0 < d <= 5.05                                   # at WPNAV_RADIUS, not at 15 m
    r = Flight("rover", params={"WP_RADIUS": 3.5})
    assert r.ap.auto.mission.wp_radius() == 3.5


def test_set_mission_current_jumps_now_in_auto_and_sets_the_resume_point_outside():
    f = Flight("copter")
    f.upload([f.at(0, 0, 10, C.MAV_CMD_NAV_TAKEOFF), f.at(20, 0, 10), f.at(20, 20, 10), f.at(0, 20, 10)])
    armed_in_guided(f)
    assert f.ap.command(C.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 10]) == C.MAV_RESULT_ACCEPTED
    f.step(6.0)
    assert f.ap.set_mission_current(3) is True               # not in AUTO: where AUTO will begin
    assert f.ap.mission_current() == (3, NOT_STARTED)
    assert f.ap.set_mode(modes.AUTO)
    f.step(0.2)
    assert f.said()[-1] == "Mission: 3 WP" and f.ap.mission_current() == (3, ACTIVE)
    assert f.ap.set_mission_current(4) is True               # in AUTO: flies there now
    assert f.said()[-1] == "Mission: 4 WP"
    f.until(lambda: 4 in f.reached_seqs(), 60, "item 4")
    assert 3 not in f.reached_seqs() and 2 not in f.reached_seqs()
    assert f.ap.set_mission_current(9) is False and f.ap.set_mission_current(float("nan")) is False


def test_unflyable_items_are_skipped_with_a_warning_never_a_crash():
    """Items the upload would refuse can still reach the store (code, an old file): a NaN
    altitude, a terrain frame, a NaN jump target and NaN params are skipped or read as 0."""
    f = Flight("copter")
    bad_alt = f.at(10, 0, float("nan"))
    terrain = f.at(10, 10, 10, frame=C.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)
    f.upload([f.at(0, 0, 8, C.MAV_CMD_NAV_TAKEOFF), bad_alt, terrain,
              f.do(C.MAV_CMD_DO_CHANGE_SPEED, param1=float("nan"), param2=float("nan")),
              f.at(15, 5, 8, param1=float("inf")), f.do(C.MAV_CMD_DO_JUMP, param1=float("nan"), param2=3)])
    armed_in_guided(f)
    f.ap.command(C.MAV_CMD_MISSION_START, [0] * 7)
    f.until(lambda: f.ap.mission_current()[1] == COMPLETE, 60, "mission complete")
    said = f.said()
    assert "item 2: altitude not finite" in said and "item 3: frame 11 not supported" in said
    assert 2 not in f.reached_seqs() and 3 not in f.reached_seqs()
    assert 5 in f.reached_seqs()                             # inf hold time read as 0
    assert f.ap.armed and f.ap.mode == modes.AUTO            # loiters at the end


def test_rover_loiter_time_and_unlimited():
    f = Flight("rover", params={"WP_RADIUS": 1.0, "WP_SPEED": 4.0})
    f.upload([f.at(10, 0, 0, C.MAV_CMD_NAV_LOITER_TIME, param1=3), f.at(10, 10, 0, C.MAV_CMD_NAV_LOITER_UNLIM)])
    f.settle()
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED and f.ap.set_mode(modes.ROVER_AUTO)
    f.until(lambda: "Reached waypoint #2" in f.said(), 60, "the unlimited loiter point")
    said = f.said()
    assert "Reached waypoint #1. Loiter for 3 seconds" in said and "Finished active loiter" in said
    t_reach = next(t for t, _, m in f.texts if m.startswith("Reached waypoint #1"))
    assert f.reached[0][1] == 1 and f.reached[0][0] - t_reach >= 3.0 - 0.05
    f.step(5.0)
    assert f.ap.mission_current() == (2, ACTIVE) and 2 not in f.reached_seqs()
    assert np.linalg.norm(f.ap.vel[:2]) < 0.1


@pytest.mark.parametrize("disarm_in_auto, resumes_at", [(True, 2), (False, 1)])
def test_rover_disarm_resets_the_mission_only_outside_auto(disarm_in_auto, resumes_at):
    f = Flight("rover", params={"WP_SPEED": 3.0})
    f.upload([f.at(8, 0, 0), f.at(30, 0, 0), f.at(30, 20, 0)])
    f.settle()
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED and f.ap.set_mode(modes.ROVER_AUTO)
    f.until(lambda: f.ap.mission_current()[0] == 2, 60, "on the leg to item 2")
    if not disarm_in_auto:
        assert f.ap.set_mode(modes.ROVER_HOLD)
    f.step(3.0)
    assert f.ap.disarm(force=True) == C.MAV_RESULT_ACCEPTED
    if not disarm_in_auto:
        assert f.ap.set_mode(modes.ROVER_AUTO)
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED
    n = len(f.texts)
    if disarm_in_auto:
        assert f.ap.set_mode(modes.ROVER_HOLD) and f.ap.set_mode(modes.ROVER_AUTO)
    f.step(0.5)
    assert f"Mission: {resumes_at} WP" in f.said()[n:]
