"""Issue 10's modes and commands in-process on the real World (fleet physics, estimator,
autopilot) stepped in sim time: BRAKE's stop from 5 m/s against ArduPilot's deceleration,
ALT_HOLD / POSHOLD holding, SMART_RTL retracing the recorded path, rover ACRO / STEERING /
LOITER / SMART_RTL, every built-in mode accepted disarmed, DO_REPOSITION,
DO_FLIGHTTERMINATION, GUIDED pause/continue; and the SmartRTL path core."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auto_world import hover_stick
from test_autopilot_behaviour import A, _fly, _goto, _until, _world
from vehicle.autopilot import modes
from vehicle.autopilot.guided import ACC_BITS, POS_BITS, YAW_IGNORE, YAW_RATE_IGNORE
from vehicle.autopilot.smartrtl import SmartRTLPath, _point_line_dist, prune_loops, simplify

VEL_MASK = POS_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE
G = 9.80665


def _cruise(w, ap, speed=5.0):
    """GUIDED velocity target north at `speed` until the copter is at it (re-sent before GUID_TIMEOUT)."""
    def at_speed():
        if w.t - at_speed.sent > 1.0:
            ap.position_target_local(A.MAV_FRAME_LOCAL_NED, VEL_MASK, (0, 0, 0), (speed, 0, 0), (0, 0, 0), 0, 0)
            at_speed.sent = w.t
        return ap.vel[0] > speed - 0.1 and abs(ap.vel[1]) < 0.1
    at_speed.sent = -10.0
    _until(w, at_speed, 30)


def brake_bound(v: float, decel: float, jerk: float) -> tuple[float, float]:
    """Time and distance of a jerk-limited stop from v (trapezoidal acceleration): the
    ArduPilot bound a BRAKE must meet (plus the vehicle's own lag)."""
    if v * jerk <= decel * decel:                 # never reaches full deceleration
        t = 2 * math.sqrt(v / jerk)
        return t, v * t / 2
    t = v / decel + decel / jerk
    return t, v * t / 2


# ------------------------------------------------------------------ copter in flight

def test_brake_stops_from_5_m_s_within_arducopters_deceleration():
    w = _world()
    ap = _fly(w, alt=10.0)
    _cruise(w, ap, 5.0)
    p0, z0 = ap.pos.copy(), ap.pos[2]
    assert ap.set_mode(modes.BRAKE)
    speeds = []

    def stopped():
        speeds.append((w.t, float(np.linalg.norm(ap.vel[:2])), ap.pos.copy()))
        return speeds[-1][1] < 0.1
    took = _until(w, stopped, 10, step=0.01)
    # BRAKE_MODE_DECEL_RATE 7.5 m/s/s, capped by ANGLE_MAX 30 deg (g tan 30 = 5.66), jerk PSC_JERK_XY 5
    decel = min(7.5, G * math.tan(math.radians(ap.params["ANGLE_MAX"] / 100)))
    t_ideal, d_ideal = brake_bound(5.0, decel, ap.params["PSC_JERK_XY"])
    dist = float(np.linalg.norm(ap.pos[:2] - p0[:2]))
    print(f"BRAKE from 5 m/s: {took:.2f} s to < 0.1 m/s, {dist:.2f} m "
          f"(ArduPilot's jerk-limited stop: {t_ideal:.2f} s, {d_ideal:.2f} m)")
    assert took <= t_ideal + 0.6                  # the vehicle's lag behind its reference
    assert dist <= d_ideal + 1.5
    # a LOITER-like slowdown at WPNAV_ACCEL (2.5 m/s/s) would need >= 2 s and 5 m: BRAKE is harder
    assert took < 5.0 / 2.5 + 0.3
    assert abs(ap.pos[2] - z0) < 0.3
    _until(w, lambda: ap.flightmodes[modes.BRAKE].stop.stop_time is not None, 5)
    w.run_for(5)                                   # then it holds the stopping point
    assert np.linalg.norm(ap.pos[:2] - ap.hold_pos[:2]) < 0.5
    assert np.linalg.norm(ap.vel) < 0.2
    # the limits it used are given back (the fleet's WPNAV_ACCEL is the parameter again)
    assert ap.fleet.params_of(0)["WPNAV_ACCEL"] == ap.params["WPNAV_ACCEL"]


def test_alt_hold_holds_altitude_and_stays_level():
    w = _world()
    ap = _fly(w, alt=8.0)
    _cruise(w, ap, 3.0)
    z0 = ap.pos[2]
    hover_stick(ap)
    assert ap.set_mode(modes.ALT_HOLD)
    zs, tilts = [], []
    for _ in range(100):
        w.run_for(0.1)
        zs.append(ap.pos[2])
        r, p, _y = ap.fleet.truth(0).euler
        tilts.append(max(abs(r), abs(p)))
    assert max(abs(z - z0) for z in zs) < 0.5
    assert max(tilts[10:]) < math.radians(3)          # sticks centred: level
    assert ap.pos[0] > 3.0                             # it drifts on (no position hold)


def test_poshold_brakes_then_holds_where_it_stopped():
    w = _world()
    ap = _fly(w, alt=8.0)
    _cruise(w, ap, 5.0)
    z0 = ap.pos[2]
    hover_stick(ap)
    assert ap.set_mode(modes.POSHOLD)
    took = _until(w, lambda: np.linalg.norm(ap.vel[:2]) < 0.1, 15, step=0.01)
    # PHLD_BRAKE_ANGLE 30 deg reached at PHLD_BRAKE_RATE 8 deg/s: a gentler stop than BRAKE
    t_ideal, _ = brake_bound(5.0, G * math.tan(math.radians(30)), G * math.radians(8))
    print(f"POSHOLD from 5 m/s: {took:.2f} s to < 0.1 m/s (ideal {t_ideal:.2f} s)")
    assert t_ideal - 1.0 <= took <= t_ideal + 0.6      # gentler than BRAKE (about 2 s)
    _until(w, lambda: ap.flightmodes[modes.POSHOLD].stop.stop_time is not None, 15)
    p1 = ap.hold_pos.copy()
    w.run_for(10)
    assert np.linalg.norm(ap.pos[:2] - p1[:2]) < 1.0
    assert abs(ap.pos[2] - z0) < 0.3


def test_smart_rtl_retraces_the_path_and_lands_where_it_armed():
    w = _world()
    ap = _fly(w, alt=5.0)
    home = ap.srtl.points[0].copy()
    corners = [np.array(c, float) for c in ((25, 0, -5), (25, 25, -8), (0, 25, -8))]
    for c in corners:
        _goto(ap, *c)
        _until(w, lambda: np.linalg.norm(ap.pos - c) < 0.5, 60)
    assert ap.set_mode(modes.SMART_RTL)
    trace = []

    def down():
        trace.append(ap.pos.copy())
        return not ap.armed
    _until(w, down, 200)
    tr = np.array(trace)
    # it goes back the way it came: past (25, 25) then (25, 0), never across the square
    near = [int(np.argmin(np.linalg.norm(tr - c, axis=1))) for c in corners[1::-1]]
    for c, k in zip(corners[1::-1], near):
        assert np.linalg.norm(tr[k] - c) < 3.0
    assert near[0] < near[1]
    assert np.min(np.linalg.norm(tr[:, :2] - [12.5, 12.5], axis=1)) > 10.0
    assert np.linalg.norm(ap.pos[:2] - home[:2]) < 1.0


def test_leaving_smart_rtl_puts_the_unreached_point_back():
    w = _world()
    ap = _fly(w, alt=5.0)
    _goto(ap, 30, 0, -5)
    _until(w, lambda: np.linalg.norm(ap.pos - [30, 0, -5]) < 0.5, 40)
    _goto(ap, 30, 30, -5)
    _until(w, lambda: np.linalg.norm(ap.pos - [30, 30, -5]) < 0.5, 40)
    assert ap.set_mode(modes.SMART_RTL)
    w.run_for(0.5)
    popped = ap.flightmodes[modes.SMART_RTL].popped.copy()
    n = len(ap.srtl.points)
    assert ap.set_mode(modes.LOITER)                  # ArduCopter's ModeSmartRTL::exit()
    assert len(ap.srtl.points) == n + 1 and np.allclose(ap.srtl.points[-1], popped)
    assert ap.set_mode(modes.SMART_RTL) and ap.set_mode(modes.LOITER)
    assert len(ap.srtl.points) == n + 1               # nothing popped in between: nothing doubled


def test_smart_rtl_refused_without_a_path_as_arducopter():
    w = _world()
    ap = _fly(w, alt=5.0)
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    ap.srtl.deactivate("buffer full")
    assert not ap.set_mode(modes.SMART_RTL)
    assert texts == ["SmartRTL deactivated: buffer full", "Mode change to SMART_RTL failed: init failed"]
    assert ap.mode == modes.GUIDED


def test_every_built_in_mode_accepted_disarmed():
    w = _world(drones=1, rovers=1)
    cap, rap = w.vehicles[0].ap, w.vehicles[1].ap
    for ap, named, follow in ((cap, modes.COPTER_MODES, modes.FOLLOW), (rap, modes.ROVER_MODES, modes.ROVER_FOLLOW)):
        # ArduCopter enters AUTO disarmed without a mission (ignore_checks); ArduRover needs one
        table = set(named) - {follow} - ({modes.ROVER_AUTO} if ap.kind == "rover" else set())
        for m in sorted(table):
            assert ap.set_mode(m), (ap.kind, m)
            w.run_for(0.1)
            assert ap.mode == m and not ap.armed
        assert not ap.set_mode(follow)                  # FOLLOW needs FOLL_ENABLE, as ArduPilot's
        assert ap.params.set("FOLL_ENABLE", 1, save=False) is None
        assert ap.set_mode(follow) and ap.mode == follow and not ap.armed
    # arming as ArduCopter allows it: not in BRAKE, SMART_RTL, RTL, LAND
    for m, ok in ((modes.BRAKE, False), (modes.SMART_RTL, False), (modes.ALT_HOLD, True), (modes.POSHOLD, True)):
        assert cap.set_mode(m)
        assert (cap.arm() == A.MAV_RESULT_ACCEPTED) is ok, m
        cap.disarm(force=True)


@pytest.mark.parametrize("action, usable, mode, said", [
    (3, True, modes.SMART_RTL, []), (4, True, modes.BRAKE, []), (5, True, modes.SMART_RTL, []),
    (3, False, modes.RTL, ["SmartRTL Unavailable, Trying RTL Mode"]),
    (5, False, modes.LAND, ["SmartRTL Unavailable, Using Land Mode"])])
def test_copter_fence_actions_smartrtl_and_brake(action, usable, mode, said):
    w = _world()
    ap = _fly(w, alt=5.0)
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    if not usable:
        ap.srtl.deactivate("bad position")
        texts.clear()
    ap.failsafe.fence_action(action, False)
    assert ap.mode == mode
    assert [t for t in texts if "Unavailable" in t] == said


def test_fence_breach_with_brake_action_stops_the_copter():
    from auto_world import Flight
    f = Flight("copter", params={"FENCE_ENABLE": 1, "FENCE_TYPE": 2, "FENCE_RADIUS": 30, "FENCE_ACTION": 4})
    f.settle()
    assert f.ap.set_mode(modes.GUIDED) and f.ap.arm() == A.MAV_RESULT_ACCEPTED
    assert f.ap.command(A.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 8]) == A.MAV_RESULT_ACCEPTED
    f.until(lambda: f.ap.pos[2] < f.ap.home[2] - 7.7, 30, "takeoff")
    for _ in range(40):
        f.ap.position_target_local(A.MAV_FRAME_LOCAL_NED, VEL_MASK, [0, 0, 0], [5, 0, 0], [0, 0, 0], 0, 0)
        f.step(0.5)
        if f.ap.mode != modes.GUIDED:
            break
    assert "Circle fence breached" in f.said() and f.ap.mode == modes.BRAKE
    f.until(lambda: np.linalg.norm(f.ap.vel[:2]) < 0.1, 5, "braked")
    assert np.linalg.norm(f.ap.pos[:2] - f.ap.home[:2]) < 30 + 8      # stopped within BRAKE's distance


def test_rover_failsafe_smartrtl_falls_back_without_a_path():
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    ap.srtl.deactivate("bad position")
    ap.failsafe.fence_action(3, False)
    assert ap.mode == modes.ROVER_RTL
    ap.set_mode(modes.ROVER_GUIDED)
    ap.failsafe.fence_action(4, False)
    assert ap.mode == modes.ROVER_HOLD


# ------------------------------------------------------------------ rover

def test_rover_acro_steering_stop_and_loiter_holds():
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    for m in (modes.ROVER_ACRO, modes.ROVER_STEERING, modes.ROVER_LOITER):
        ap.set_mode(modes.ROVER_GUIDED)
        ap.position_target_local(A.MAV_FRAME_LOCAL_NED, VEL_MASK, (0, 0, 0), (3, 0, 0), (0, 0, 0), 0, 0)
        _until(w, lambda: ap.vel[0] > 2.5, 10)
        assert ap.set_mode(m)
        _until(w, lambda: np.linalg.norm(ap.vel[:2]) < 0.05, 6)   # throttle centred: stopped
        p = ap.pos.copy()
        w.run_for(5)
        assert np.linalg.norm(ap.pos[:2] - p[:2]) < 0.3
    # LOITER drives back when pushed beyond LOIT_RADIUS (2 m) from its point
    lp = ap.hold_pos.copy()
    ap.fleet.phys.px[0] += 4.0                         # a shove, on truth
    _until(w, lambda: np.linalg.norm(ap.pos[:2] - lp[:2]) <= 2.0 and np.linalg.norm(ap.vel[:2]) < 0.05, 20)


def test_rover_smart_rtl_retraces_and_says_reached_destination():
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    texts = []
    ap.outbox.subscribe(text=lambda sev, t: texts.append(t))
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    start = ap.pos.copy()
    legs = [start + d for d in (np.array([30, 0, 0]), np.array([30, 30, 0]))]
    for c in legs:
        _goto(ap, *c)
        _until(w, lambda: np.linalg.norm(ap.pos[:2] - c[:2]) < 2.5, 60)
    assert ap.set_mode(modes.ROVER_SMART_RTL)
    trace = []

    def done():
        trace.append(ap.pos.copy())
        return "Reached destination" in texts
    _until(w, done, 120)
    tr = np.array(trace)
    assert np.min(np.linalg.norm(tr[:, :2] - legs[0][:2], axis=1)) < 3.5     # back via the corner
    assert np.linalg.norm(ap.pos[:2] - start[:2]) < ap.params["WP_RADIUS"] + 0.6
    _until(w, lambda: np.linalg.norm(ap.vel[:2]) < 0.05, 10)


# ------------------------------------------------------------------ commands

def _reposition(ap, lat, lon, alt, flags=1, frame=A.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, speed=-1.0):
    return ap.command(A.MAV_CMD_DO_REPOSITION, [speed, flags, 0, math.nan, lat * 1e7, lon * 1e7, alt],
                      frame, int(lat * 1e7), int(lon * 1e7))


def test_do_reposition_switches_to_guided_and_arrives():
    w = _world()
    ap = _fly(w, alt=5.0)
    assert ap.set_mode(modes.LOITER)
    from common import geo
    lat, lon, _ = geo.ned_to_lla(ap.origin, (20.0, -10.0, 0.0))
    assert _reposition(ap, lat, lon, 8.0, flags=0) == A.MAV_RESULT_DENIED      # not GUIDED, no flag
    assert ap.mode == modes.LOITER
    assert _reposition(ap, 91.0, lon, 8.0) == A.MAV_RESULT_DENIED
    assert _reposition(ap, lat, lon, 0.0) == A.MAV_RESULT_DENIED               # relative 0: "current"
    assert ap.command(A.MAV_CMD_DO_REPOSITION, [-1, 1, 0, 0, 0, 0, 8], A.MAV_FRAME_GLOBAL_INT, 0, 0) \
        == A.MAV_RESULT_DENIED
    assert _reposition(ap, lat, lon, math.nan) == A.MAV_RESULT_DENIED
    assert _reposition(ap, lat, lon, 8.0) == A.MAV_RESULT_ACCEPTED
    assert ap.mode == modes.GUIDED
    home_z = ap.home[2]
    _until(w, lambda: np.linalg.norm(ap.pos - [20, -10, home_z - 8]) < 0.5, 40)


def test_rover_do_reposition_takes_param1_as_speed():
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    assert ap.set_mode(modes.ROVER_HOLD) and ap.arm() == A.MAV_RESULT_ACCEPTED
    from common import geo
    lat, lon, _ = geo.ned_to_lla(ap.origin, ap.pos + [60.0, 0.0, 0.0])
    assert _reposition(ap, lat, lon, 5.0, speed=3.0) == A.MAV_RESULT_ACCEPTED
    assert ap.mode == modes.ROVER_GUIDED
    w.run_for(10)
    assert 2.7 < np.linalg.norm(ap.vel[:2]) < 3.2      # param1, not CRUISE_SPEED (8 m/s)


def test_flight_termination_disarms_at_once():
    w = _world()
    ap = _fly(w, alt=5.0)
    assert ap.command(A.MAV_CMD_DO_FLIGHTTERMINATION, [0] + [0] * 6) == A.MAV_RESULT_FAILED
    assert ap.armed
    assert ap.command(A.MAV_CMD_DO_FLIGHTTERMINATION, [math.nan] + [0] * 6) == A.MAV_RESULT_DENIED
    assert ap.command(A.MAV_CMD_DO_FLIGHTTERMINATION, [1] + [0] * 6) == A.MAV_RESULT_ACCEPTED
    assert not ap.armed
    _until(w, lambda: ap.fleet.truth(0).pos[2] > -0.5, 10)          # it falls


def test_guided_pause_holds_and_continue_resumes():
    w = _world()
    ap = _fly(w, alt=5.0)
    _goto(ap, 40, 0, -5)
    _until(w, lambda: ap.vel[0] > 3.0, 20)
    assert ap.command(A.MAV_CMD_DO_PAUSE_CONTINUE, [0] + [0] * 6) == A.MAV_RESULT_ACCEPTED
    w.run_for(6)
    x = ap.pos[0]
    assert np.linalg.norm(ap.vel) < 0.3 and x < 35
    w.run_for(3)
    assert abs(ap.pos[0] - x) < 0.5
    assert ap.command(A.MAV_CMD_DO_PAUSE_CONTINUE, [1] + [0] * 6) == A.MAV_RESULT_ACCEPTED
    _until(w, lambda: np.linalg.norm(ap.pos - [40, 0, -5]) < 0.5, 30)
    assert ap.set_mode(modes.LOITER)
    assert ap.command(A.MAV_CMD_DO_PAUSE_CONTINUE, [0] + [0] * 6) == A.MAV_RESULT_FAILED


# ------------------------------------------------------------------ the SmartRTL path core

pts3 = st.lists(st.tuples(*[st.floats(-100, 100, allow_nan=False)] * 3), min_size=2, max_size=40)


@settings(max_examples=60, deadline=None)
@given(pts3, st.floats(0.1, 5.0))
def test_simplify_keeps_ends_and_every_dropped_point_is_near_the_kept_path(raw, eps):
    pts = [np.array(p) for p in raw]
    out = simplify(pts, eps)
    assert np.array_equal(out[0], pts[0]) and np.array_equal(out[-1], pts[-1])
    kept = {tuple(p) for p in out}
    for p in pts:
        if tuple(p) not in kept:
            assert min(_point_line_dist(p, a, b) for a, b in zip(out, out[1:])) <= eps + 1e-9


def test_prune_cuts_a_loop():
    # out east, a loop north and back across the outbound leg, then on east
    pts = [np.array(p, float) for p in ((0, 0, 0), (10, 0, 0), (20, 0, 0), (20, 10, 0), (15, 10, 0),
                                        (15, -5, 0), (30, -5, 0))]
    out = prune_loops(pts, 1.98)
    assert len(out) < len(pts)
    assert not any(np.allclose(p, (20, 10, 0)) for p in out)


def test_path_records_at_accuracy_and_deactivates_when_full():
    said = []
    path = SmartRTLPath(accuracy=2.0, points_max=10, text=lambda s, m: said.append(m))
    path.record(np.zeros(3), True, True, False, 0.0)
    assert len(path.points) == 1 and path.active
    path.record(np.array([1.0, 0, 0]), True, True, False, 0.1)
    assert len(path.points) == 1                     # under SRTL_ACCURACY from the last point
    t = 0.2
    for k in range(200):                              # a zig-zag that cannot be simplified away
        t += 0.5
        path.record(np.array([3.0 * k, 10.0 * (k % 2), 0]), True, True, False, t)
        if not path.active:
            break
    assert said == ["SmartRTL deactivated: buffer full"]
    assert 20.0 <= t <= 21.0                        # SMARTRTL_TIMEOUT after the last point saved
