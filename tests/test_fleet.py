"""Fleet contract and batching: n vehicles step like n independent ones."""
from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle import params_core
from vehicle.control.copter import CopterGains
from vehicle.control.rover import RoverGains
from vehicle.fleet import CopterFleet, RoverFleet, Setpoint
from vehicle.fleet_base import VehicleState

DT = 1.0 / 400.0
TARGETS = [np.array([5.0, 0.0, -4.0]), np.array([-3.0, 6.0, -8.0]), np.array([2.0, -2.0, -2.0])]


def fly(f, n, secs):
    for i in range(n):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=f.home[i] + TARGETS[i]))
    for _ in range(int(round(secs / DT))):
        f.step(DT)


@pytest.mark.parametrize("estimator", [False, True])
@pytest.mark.parametrize("scalar", [False, True])
def test_batched_equals_single_runs(estimator, scalar):
    seeds = [5, 6, 7]
    home = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, -1.0]])
    batch = CopterFleet(3, seed=seeds, home=home, estimator=estimator, scalar=scalar)
    fly(batch, 3, 4.0)
    for i in range(3):
        one = CopterFleet(1, seed=[seeds[i]], home=home[i:i + 1], estimator=estimator)
        one.set_armed(0, True)
        one.set_setpoint(0, Setpoint(pos=home[i] + TARGETS[i]))
        for _ in range(int(round(4.0 / DT))):
            one.step(DT)
        np.testing.assert_allclose(batch.truth(i).pos, one.truth(0).pos, atol=1e-6)
        np.testing.assert_allclose(batch.estimate(i).pos, one.estimate(0).pos, atol=1e-6)
        np.testing.assert_allclose(batch.truth(i).quat, one.truth(0).quat, atol=1e-6)


def test_vehicles_are_independent():
    """Changing vehicle 1's target does not change vehicle 0 at all."""
    a = CopterFleet(2, seed=1)
    b = CopterFleet(2, seed=1)
    for f, tgt in ((a, [0, 5, -5.0]), (b, [9, -9, -3.0])):
        for i in range(2):
            f.set_armed(i, True)
        f.set_setpoint(0, Setpoint(pos=[1, 1, -3.0]))
        f.set_setpoint(1, Setpoint(pos=tgt))
        for _ in range(1200):
            f.step(DT)
    assert np.array_equal(a.truth(0).pos, b.truth(0).pos)
    assert not np.allclose(a.truth(1).pos, b.truth(1).pos)


def _attitude_flight(scalar: bool, attitude: bool) -> CopterFleet:
    """Three copters up 5 m, then (attitude) vehicle 0 leans to 20 deg of roll holding its
    altitude and vehicle 1 flies a thrust of 0.5 pitched 10 deg with a roll-rate feed-forward;
    vehicle 2 keeps its position target throughout."""
    f = CopterFleet(3, seed=[1, 2, 3], home=np.array([[0.0, 0, 0], [10.0, 0, 0], [0, 10.0, 0]]),
                    estimator=True, scalar=scalar)
    for i in range(3):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=f.home[i] + [0.0, 0.0, -5.0]))
    for _ in range(int(4.0 / DT)):
        f.step(DT)
    if attitude:
        f.set_setpoint(0, Setpoint(roll=math.radians(20), pitch=0.0, yaw=0.0, vel=[0.0, 0.0, 0.0]))
        f.set_setpoint(1, Setpoint(roll=0.0, pitch=math.radians(-10), yaw=0.5, yaw_rate=0.0, vel=[0, 0, 0],
                                   rates=(0.01, 0.0), thrust=0.5))
    for _ in range(int(3.0 / DT)):
        f.step(DT)
    return f


def test_attitude_setpoints_flown_alike_by_both_backends_and_alone():
    """An attitude target (vehicle/fleet.py: roll, pitch, rates, thrust) in a batch: the
    numpy and the scalar backends give the same flight, the lean asked is flown, and the
    vehicle beside it flies exactly as it would without them."""
    a, b = _attitude_flight(False, True), _attitude_flight(True, True)
    for i in range(3):
        np.testing.assert_allclose(a.truth(i).pos, b.truth(i).pos, atol=1e-6)
        np.testing.assert_allclose(a.truth(i).quat, b.truth(i).quat, atol=1e-6)
    roll, pitch, _ = a.truth(0).euler
    assert math.degrees(roll) == pytest.approx(20.0, abs=1.0) and abs(math.degrees(pitch)) < 1.0
    assert abs(a.truth(0).pos[2] + 5.0) < 0.3                     # climb rate 0: altitude held
    roll, pitch, yaw = a.truth(1).euler
    assert math.degrees(pitch) == pytest.approx(-10.0, abs=1.0) and yaw == pytest.approx(0.5, abs=0.05)
    assert a.ctrl.coll[1] == pytest.approx(0.5 / math.cos(math.radians(10)), abs=0.02)   # angle boost
    assert np.array_equal(a.truth(2).pos, _attitude_flight(False, False).truth(2).pos)


def test_contract_api_shapes_and_types():
    f = CopterFleet(2, params={"WPNAV_SPEED": 300}, seed=0, home=np.zeros((2, 3)))
    assert f.n == 2 and f.sim_time == 0.0
    f.step(DT)
    assert f.sim_time == pytest.approx(DT)
    for arr, w in ((f.est_pos, 3), (f.est_vel, 3), (f.est_quat, 4), (f.est_rates, 3), (f.pos, 3), (f.quat, 4)):
        assert arr.shape == (2, w)
    s = f.estimate(1)
    assert isinstance(s, VehicleState) and s.pos.shape == (3,) and s.quat.shape == (4,)
    assert isinstance(s.yaw, float)
    assert isinstance(f.landed(0), bool) and isinstance(f.estimate_ok(0), bool)
    assert f.gains.v_xy == pytest.approx(3.0)
    f.set_params({"WPNAV_SPEED": 800, "NOT_A_PARAM": 1})
    assert f.gains.v_xy == pytest.approx(8.0)
    r = RoverFleet(1, seed=0)
    r.step(DT)
    assert r.est_pos.shape == (1, 3) and r.truth(0).pos[2] == 0.0 and r.landed(0)


def test_land_detection_in_a_batch():
    f = CopterFleet(3, seed=2, scalar=False)
    for i in range(3):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=[0, 0, -3.0 - i]))
    for _ in range(int(8 / DT)):
        f.step(DT)
    assert not f.landed_mask.any()
    f.set_setpoint(1, f.land_setpoint(1))
    for _ in range(int(12 / DT)):
        f.step(DT)
    assert list(f.landed_mask) == [False, True, False]
    assert f.truth(1).pos[2] == 0.0


def test_estimator_off_fleet_flies_on_truth():
    f = CopterFleet(50, seed=0, estimator=False, home=np.column_stack([np.arange(50.0), np.zeros(50), np.zeros(50)]))
    assert not f.scalar
    for i in range(50):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=f.home[i] + [0, 0, -5.0]))
    for _ in range(int(8 / DT)):
        f.step(DT)
    np.testing.assert_allclose(f.est_pos, f.pos)
    assert np.all(np.abs(f.pos[:, 2] + 5.0) < 0.05)


def test_params_core_table():
    for kind, table in (("copter", params_core.COPTER_PARAMS), ("rover", params_core.ROVER_PARAMS)):
        for name, d in table.items():
            assert name == name.upper() and len(name) <= 16          # MAVLink param_id limit
            assert d.lo <= d.default <= d.hi, name
            assert params_core.validate(kind, name, d.default)
        assert not params_core.validate(kind, "NOPE", 1.0)
    assert params_core.defaults()["WPNAV_SPEED"] == 500
    assert params_core.defaults()["ANGLE_MAX"] == 3000
    assert params_core.defaults("rover")["CRUISE_SPEED"] >= 6
    assert not params_core.validate("copter", "ANGLE_MAX", 9000)
    # the defaults become the cores' gains in SI units (ArduPilot's cm, cdeg and deg to m, rad)
    g = CopterGains(params_core.defaults("copter"))
    assert (g.v_xy, g.v_up, g.v_dn) == pytest.approx((5.0, 2.5, 1.5))           # m/s
    assert (g.a_xy, g.a_z, g.j_xy, g.j_z) == pytest.approx((2.5, 1.0, 5.0, 5.0))  # m/s², m/s³
    assert g.angle_max == pytest.approx(math.pi / 6) and g.tan_angle_max == pytest.approx(3 ** -0.5)
    assert g.land_speed == pytest.approx(0.5) and g.imax_xy == pytest.approx(10.0)
    assert (g.rate_y_max, g.rate_rp_max) == pytest.approx((math.pi / 2, 2 * math.pi))  # rad/s
    # a changed parameter reaches the gain; a rate limit of 0 (none) falls back to a default
    g = CopterGains({**params_core.defaults("copter"), "WPNAV_SPEED": 1200.0, "ANGLE_MAX": 4500.0,
                     "ATC_RATE_Y_MAX": 0.0})
    assert g.v_xy == pytest.approx(12.0) and g.tan_angle_max == pytest.approx(1.0)
    assert g.rate_y_max == pytest.approx(math.pi / 2)
    r = RoverGains(params_core.defaults("rover"))
    assert r.cruise == pytest.approx(8.0)              # WP_SPEED 0: CRUISE_SPEED is used
    assert r.accel == pytest.approx(5.0) and r.decel == pytest.approx(5.0)   # ATC_DECEL_MAX 0: = accel
    assert r.max_rate == pytest.approx(4 * math.pi / 3) and r.pivot == pytest.approx(math.pi / 2)
    assert r.radius == pytest.approx(0.3) and r.max_speed == pytest.approx(12.0)
    r = RoverGains({**params_core.defaults("rover"), "WP_SPEED": 3.0, "ATC_DECEL_MAX": 2.0})
    assert (r.cruise, r.decel) == pytest.approx((3.0, 2.0))


@pytest.mark.parametrize("estimator", [False, True])
def test_rover_batched_equals_single_runs(estimator):
    seeds = [3, 4]
    home = np.array([[0.0, 0.0, 0.0], [5.0, 5.0, 0.0]])
    goals = [np.array([20.0, -10.0, 0.0]), np.array([-15.0, 8.0, 0.0])]
    batch = RoverFleet(2, seed=seeds, home=home, estimator=estimator, scalar=False)
    for i in range(2):
        batch.set_armed(i, True)
        batch.set_setpoint(i, Setpoint(pos=goals[i]))
    for _ in range(int(5 / DT)):
        batch.step(DT)
    for i in range(2):
        one = RoverFleet(1, seed=[seeds[i]], home=home[i:i + 1], estimator=estimator)
        assert one.scalar
        one.set_armed(0, True)
        one.set_setpoint(0, Setpoint(pos=goals[i]))
        for _ in range(int(5 / DT)):
            one.step(DT)
        np.testing.assert_allclose(batch.truth(i).pos, one.truth(0).pos, atol=1e-6)
        np.testing.assert_allclose(batch.estimate(i).pos, one.estimate(0).pos, atol=1e-6)


def test_bad_setpoints_never_fly_somewhere_odd():
    f = CopterFleet(1, seed=0)
    f.set_armed(0, True)
    f.set_setpoint(0, Setpoint(pos=[0, 0, -5.0]))
    for _ in range(int(8 / DT)):
        f.step(DT)
    f.set_setpoint(0, Setpoint(pos=[np.nan, np.nan, -5.0], vel=[np.inf, 0, 0], yaw=np.nan, yaw_rate=np.inf))
    for _ in range(int(3 / DT)):
        f.step(DT)
    st = f.truth(0)
    assert np.all(np.isfinite(st.pos)) and np.all(np.isfinite(st.quat))
    assert np.linalg.norm(st.pos - [0, 0, -5.0]) < 0.5
    r = RoverFleet(1, seed=0)
    r.set_armed(0, True)
    r.set_setpoint(0, Setpoint(pos=[np.nan, 1, 0], vel=[np.nan, np.inf, 0], yaw=np.nan))
    for _ in range(400):
        r.step(DT)
    assert np.linalg.norm(r.truth(0).pos) < 1e-9


def _max_speeds(f, goals, secs):
    """Arm all, send vehicle i to goals[i], step secs; (n,) max true horizontal speed."""
    for i in range(f.n):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=goals[i]))
    top = np.zeros(f.n)
    for _ in range(int(round(secs / DT))):
        f.step(DT)
        top = np.maximum(top, np.hypot(f.vel[:, 0], f.vel[:, 1]))
    return top


@pytest.mark.parametrize("scalar", [True, False])
def test_copter_params_per_vehicle(scalar):
    """PARAM_SET on one ArduPilot changes that vehicle only: WPNAV_SPEED set on vehicle 0
    limits vehicle 0's 20 m move while vehicle 1 flies at the default 5 m/s; both store
    paths (floats per vehicle, numpy (n,) gains) fly the same numbers."""
    home = np.array([[0.0, 0.0, 0.0], [0.0, 5.0, 0.0]])
    f = CopterFleet(2, seed=3, home=home, estimator=False, scalar=scalar)
    f.set_params({"WPNAV_SPEED": 200}, i=0)
    assert f.params_of(0)["WPNAV_SPEED"] == 200 and f.params_of(1)["WPNAV_SPEED"] == 500
    assert f.gains_of(0).v_xy == pytest.approx(2.0) and f.gains_of(1).v_xy == pytest.approx(5.0)
    top = _max_speeds(f, home + [20.0, 0.0, -5.0], 8.0)
    assert top[0] <= 2.0 * 1.05, top
    assert 4.8 <= top[1] <= 5.0 * 1.05, top
    # the other store path gives the same flight (per-vehicle gains broadcast as (n,) arrays)
    other = CopterFleet(2, seed=3, home=home, estimator=False, scalar=not scalar)
    other.set_params({"WPNAV_SPEED": 200}, i=0)
    _max_speeds(other, home + [20.0, 0.0, -5.0], 8.0)
    np.testing.assert_allclose(other.pos, f.pos, atol=1e-6)
    # i=None keeps its meaning: every vehicle
    f.set_params({"WPNAV_SPEED": 300})
    assert [f.params_of(i)["WPNAV_SPEED"] for i in range(2)] == [300, 300]
    assert f.gains_of(0).v_xy == f.gains_of(1).v_xy == f.gains.v_xy == pytest.approx(3.0)
    top = _max_speeds(f, home + [0.0, 0.0, -5.0], 8.0)        # fly back: both at 3 m/s
    assert np.all((2.85 <= top) & (top <= 3.0 * 1.05)), top
    with pytest.raises(IndexError):
        f.set_params({"WPNAV_SPEED": 300}, i=2)


@pytest.mark.parametrize("scalar", [True, False])
@pytest.mark.parametrize("name", ["CRUISE_SPEED", "WP_SPEED"])
def test_rover_params_per_vehicle(scalar, name):
    home = np.array([[0.0, 0.0, 0.0], [0.0, 5.0, 0.0]])
    f = RoverFleet(2, seed=3, home=home, estimator=False, scalar=scalar)
    f.set_params({name: 2.0}, i=0)
    assert f.gains_of(0).cruise == 2.0 and f.gains_of(1).cruise == params_core.defaults("rover")["CRUISE_SPEED"]
    top = _max_speeds(f, home + [20.0, 0.0, 0.0], 6.0)
    assert 1.9 <= top[0] <= 2.0 + 1e-6, top
    assert top[1] >= 5.5, top                                  # default CRUISE_SPEED 8 m/s, 20 m leg
    f.set_params({name: 3.0})
    assert f.gains_of(0).cruise == f.gains_of(1).cruise == f.gains.cruise == 3.0
    top = _max_speeds(f, home + [40.0, 0.0, 0.0], 6.0)
    assert np.all((2.9 <= top) & (top <= 3.0 + 1e-6)), top


def _gps_off_landing(scalar: bool, estimator) -> tuple[CopterFleet, list[float | None]]:
    """Two copters hovering 5 m up; vehicle 0 loses GPS (SIM_GPS1_ENABLE 0), and 17 s later,
    its filter no longer aiding (vehicle.no_aiding, after 15 s), both descend level at 0.5 m/s
    as LAND does without a position. Returns the fleet and when each was detected landed."""
    from vehicle.sim_faults import SimFaults
    f = CopterFleet(2, seed=[3, 4], home=np.array([[0.0, 0.0, 0.0], [6.0, 0.0, 0.0]]), estimator=estimator,
                    scalar=scalar)
    for i in range(2):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=f.home[i] + [0.0, 0.0, -5.0]))
    for _ in range(int(8 / DT)):
        f.step(DT)
    f.set_faults(0, SimFaults(gps_enabled=False))
    for _ in range(int(17 / DT)):
        f.step(DT)
    assert f.estimator.no_aiding.active == [True, False]
    for i in range(2):
        f.set_setpoint(i, Setpoint(vel=[0.0, 0.0, 0.5], level=True))
    landed: list[float | None] = [None, None]
    for k in range(int(16 / DT)):
        f.step(DT)
        for i in range(2):
            if landed[i] is None and f.landed(i):
                landed[i] = k * DT
    return f, landed


def test_land_detector_without_gps_alike_in_both_forms():
    """ArduCopter's land detector has no horizontal-speed test: a copter whose filter stopped
    aiding touches down and is detected landed like its GPS neighbour (within a second), and
    the scalar and numpy forms give the same numbers (landing step, filtered acceleration,
    estimate)."""
    (a, la), (b, lb) = _gps_off_landing(True, True), _gps_off_landing(False, True)
    assert la == lb and None not in la and abs(la[0] - la[1]) < 1.0
    np.testing.assert_allclose(a.est_pos, b.est_pos, atol=1e-9)
    for k in ("lax", "lay", "laz", "att_err"):
        np.testing.assert_allclose(getattr(a.ctrl, k), getattr(b.ctrl, k), atol=1e-12)
    c, lc = _gps_off_landing(False, "batched")      # BatchedKF's no-aiding path: the same filter
    assert lc == la
    np.testing.assert_allclose(c.est_pos, a.est_pos, atol=1e-6)
