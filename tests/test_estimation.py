"""Sensors + filterpy estimator: convergence, error vs truth, determinism by seed."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sim_support import run

from vehicle.fleet import CopterFleet, RoverFleet, Setpoint
from vehicle.sensors import Sensors, SensorSpec, vehicle_rngs


def test_estimate_converges_and_estimate_ok():
    f = CopterFleet(1, seed=3, home=np.array([[5.0, -3.0, 0.0]]))
    assert not f.estimate_ok(0)
    run(f, 0.5)
    assert not f.estimate_ok(0)                   # needs 10 GPS fixes
    run(f, 1.5)
    assert f.estimate_ok(0)
    assert np.linalg.norm(f.estimate(0).pos - [5.0, -3.0, 0.0]) < 0.3


def test_estimate_error_bounded_in_flight():
    f = CopterFleet(1, seed=12)
    f.set_armed(0, True)
    f.set_setpoint(0, Setpoint(pos=[0, 0, -10.0]))
    run(f, 8.0)
    f.set_setpoint(0, Setpoint(pos=[25.0, -10.0, -15.0], yaw=1.0))
    e_pos, e_vel, e_att = [], [], []

    def cb(f):
        t, e = f.truth(0), f.estimate(0)
        e_pos.append(np.linalg.norm(e.pos - t.pos))
        e_vel.append(np.linalg.norm(e.vel - t.vel))
        d = abs(float(np.dot(e.quat, t.quat)))
        e_att.append(2 * math.degrees(math.acos(min(1.0, d))))
    run(f, 20.0, cb)
    assert math.sqrt(np.mean(np.square(e_pos))) < 0.2
    assert max(e_pos) < 0.6
    assert math.sqrt(np.mean(np.square(e_vel))) < 0.15
    assert max(e_att) < 2.0
    # the estimate is not truth: the noise is there
    assert np.mean(e_pos) > 0.01


def test_deterministic_with_seed_and_differs_across_seeds():
    def fly(seed):
        f = CopterFleet(1, seed=seed)
        f.set_armed(0, True)
        f.set_setpoint(0, Setpoint(pos=[3, 2, -6.0]))
        run(f, 4.0)
        return f.estimate(0).pos, f.truth(0).pos
    a, b, c = fly(5), fly(5), fly(6)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.allclose(a[0], c[0], atol=1e-6)


def test_sensor_noise_levels():
    spec = SensorSpec()
    n = 2000
    s = Sensors(vehicle_rngs(1, n), spec)
    pos = np.zeros((n, 3))
    quat = np.tile([0, 0, 0, 1.0], (n, 1))
    s.sample(True, True, pos, pos, pos, quat)
    assert np.std(s.gps_pos[:, 0]) == pytest.approx(spec.gps_pos_sigma, rel=0.1)
    assert np.std(s.gps_vel[:, 1]) == pytest.approx(spec.gps_vel_sigma, rel=0.1)
    assert np.std(s.baro_alt) == pytest.approx(spec.baro_sigma, rel=0.1)
    # at rest, level: accelerometer reads -g on body z (plus bias and noise)
    assert np.mean(s.accel[:, 2]) == pytest.approx(-9.80665, abs=0.01)
    assert np.std(s.accel[:, 0]) == pytest.approx(math.hypot(spec.accel_sigma, spec.accel_bias_sigma), rel=0.1)
    g = s.gyro_noise()
    assert np.std(g[:, 0]) == pytest.approx(math.hypot(spec.gyro_sigma, spec.gyro_bias_sigma), rel=0.1)


def test_rover_estimator_tracks():
    f = RoverFleet(1, seed=2)
    f.set_armed(0, True)
    f.set_setpoint(0, Setpoint(vel=[3.0, 1.0, 0.0]))
    errs = []
    run(f, 10.0, lambda f: errs.append(np.linalg.norm(f.estimate(0).pos[:2] - f.truth(0).pos[:2])))
    assert f.estimate_ok(0)
    assert math.sqrt(np.mean(np.square(errs[-2000:]))) < 0.25


def test_batched_kf_matches_filterpy():
    """BatchedKF (big fleets) runs the per-vehicle filters' equations (the sequential GPS and
    baro updates included): the same numbers to rounding (its predict multiplies in another order)."""
    from vehicle.estimation import BatchedKF, make_kf
    rng = np.random.default_rng(4)
    n = 5
    p0 = rng.normal(size=(n, 3))
    kfs = [make_kf(0.01, p0[i], 0.08, 0.3, 0.45, 0.1) for i in range(n)]
    b = BatchedKF(make_kf(0.01, np.zeros(3), 0.08, 0.3, 0.45, 0.1), p0)
    Hb = np.zeros((1, 9))
    Hb[0, 2] = 1.0
    Rb = np.array([[0.01]])
    for k in range(60):
        u = rng.normal(size=(n, 3))
        b.predict(u)
        for i in range(n):
            kfs[i].predict(u=u[i])
        if k % 10 == 0:
            z = rng.normal(size=(n, 6))
            b.update(z)
            for i in range(n):
                kfs[i].update(z[i])
        if k % 2 == 0:
            zb = rng.normal(size=(n, 1))
            b.update(zb, R=Rb, H=Hb)
            for i in range(n):
                kfs[i].update(zb[i], R=Rb, H=Hb)
    for i in range(n):
        np.testing.assert_allclose(b.x[i], kfs[i].x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.P[i], kfs[i].P, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.y[i], kfs[i].y, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(b.S[i], kfs[i].S, rtol=1e-9, atol=1e-12)


def test_fleet_filterpy_and_batched_estimators_agree():
    a = CopterFleet(3, seed=[1, 2, 3], estimator="filterpy")
    b = CopterFleet(3, seed=[1, 2, 3], estimator="batched")
    assert not a.estimator.batched and b.estimator.batched
    for f in (a, b):
        for i in range(3):
            f.set_armed(i, True)
            f.set_setpoint(i, Setpoint(pos=[i, -i, -4.0]))
        run(f, 3.0)
    np.testing.assert_allclose(a.est_pos, b.est_pos, atol=1e-6)
    assert [a.estimate_ok(i) for i in range(3)] == [b.estimate_ok(i) for i in range(3)] == [True] * 3
    assert a.estimator.kfs and not b.estimator.kfs
    assert not CopterFleet(2, seed=0).estimator.batched      # the SITL-size default is filterpy
    assert CopterFleet(20, seed=0).estimator.batched         # big fleets: BatchedKF


def test_sensor_rows_are_the_vectorised_samples_to_the_bit():
    """sample_rows (a few vehicles, on floats) and sample (numpy) draw the same noise and
    compute the same readings, bit for bit."""
    n = 3
    rng = np.random.default_rng(9)
    pos, vel, acc = rng.normal(size=(3, n, 3)) * [[10.0], [2.0], [3.0]]
    q = rng.normal(size=(n, 4))
    quat = q / np.linalg.norm(q, axis=1, keepdims=True)
    a, b = Sensors(vehicle_rngs(4, n)), Sensors(vehicle_rngs(4, n))
    for k in range(6):
        gps, baro = k % 3 == 0, k % 2 == 0
        a.sample(gps, baro, pos, vel, acc, quat)
        z, accel, gps_pos, gps_vel, baro_alt = b.sample_rows(gps, baro, pos.tolist(), vel.tolist(), acc.tolist(),
                                                             quat.tolist())
        assert np.array_equal(a.z, np.array(z)) and np.array_equal(a.accel, np.array(accel))
        if gps:
            assert np.array_equal(a.gps_pos, np.array(gps_pos)) and np.array_equal(a.gps_vel, np.array(gps_vel))
        else:
            assert gps_pos is None and gps_vel is None
        if baro:
            assert np.array_equal(a.baro_alt, np.array(baro_alt))
        else:
            assert baro_alt is None


def _joint_update(x, P, z, H, R):
    """filterpy's joint update (K = PH' inv(S), Joseph form) of x (9,), P (9, 9)."""
    from filterpy.kalman import KalmanFilter
    kf = KalmanFilter(dim_x=9, dim_z=len(H))
    kf.x, kf.P, kf.H, kf.R = x.copy(), P.copy(), H, R
    kf.update(z)
    return kf


_SEEDS = st.integers(min_value=0, max_value=2 ** 32 - 1)


@settings(max_examples=60, deadline=None)
@given(seed=_SEEDS, m=st.integers(min_value=1, max_value=6), coupled=st.booleans())
def test_sequential_update_is_the_joint_kalman_update(seed, m, coupled):
    """The filters' update fuses a direct observation with diagonal R scalar by scalar (EKF3's
    sequential fusion, no inverse): the posterior of filterpy's joint update to rounding, for
    a dense P (every state correlated) or the estimator's per-axis one; y and S are filterpy's."""
    from vehicle.estimation import make_kf
    rng = np.random.default_rng(seed)
    kf = make_kf(0.01, np.zeros(3), 0.08, 0.3, 0.45, 0.1)
    if coupled:
        A = rng.normal(size=(9, 9))
        P = A @ A.T + np.eye(9) * 0.1
    else:
        for _ in range(rng.integers(1, 200)):
            kf.predict(u=rng.normal(size=3))
        P = kf.P.copy()
    x = rng.normal(size=9) * 5.0
    states = rng.choice(9, size=m, replace=False)
    H = np.zeros((m, 9))
    H[np.arange(m), states] = 1.0
    R = np.diag(rng.lognormal(-2.0, 2.0, size=m))
    z = rng.normal(size=m) * 3.0
    ref = _joint_update(x, P, z, H, R)
    kf.x, kf.P = x.copy(), P.copy()
    kf.update(z, R=R, H=H)
    np.testing.assert_allclose(kf.x, ref.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(kf.P, ref.P, rtol=1e-7, atol=1e-9 * np.abs(P).max())
    np.testing.assert_array_equal(kf.y, ref.y)
    np.testing.assert_array_equal(kf.S, ref.S)
    if np.array_equal(P, P.T):
        assert np.array_equal(kf.P, kf.P.T)         # the update is exactly symmetric
    assert kf.K is None and kf.SI is None       # no gain matrix, no inverse
    assert kf.mahalanobis == pytest.approx(ref.mahalanobis, rel=1e-9)
    assert kf.log_likelihood == pytest.approx(ref.log_likelihood, rel=1e-9, abs=1e-9)


def test_sequential_update_leaves_other_forms_to_filterpy():
    """A measurement that is not a direct observation (a row of H mixing states) or has
    correlated noise takes filterpy's joint update unchanged, bit for bit."""
    from vehicle.estimation import make_kf
    rng = np.random.default_rng(3)
    A = rng.normal(size=(9, 9))
    P, x = A @ A.T + np.eye(9), rng.normal(size=9)
    mixed = np.zeros((2, 9))
    mixed[0, 0] = mixed[1, 3] = 1.0
    mixed[1, 4] = 0.5
    correlated = np.array([[1.0, 0.2], [0.2, 1.0]])
    direct = np.zeros((2, 9))
    direct[0, 0] = direct[1, 3] = 1.0
    for H, R in ((mixed, np.eye(2)), (direct, correlated), (direct * 2.0, np.eye(2))):
        kf = make_kf(0.01, np.zeros(3), 0.08, 0.3, 0.45, 0.1)
        kf.x, kf.P = x.copy(), P.copy()
        kf.update(np.array([1.0, 2.0]), R=R, H=H)
        ref = _joint_update(x, P, np.array([1.0, 2.0]), H, R)
        assert np.array_equal(kf.x, ref.x) and np.array_equal(kf.P, ref.P) and kf.K is not None


def test_sequential_update_follows_edits_of_H_and_R():
    """H and R are recognised by their contents: editing the filter's R in place is seen."""
    from vehicle.estimation import make_kf
    kf = make_kf(0.01, np.zeros(3), 0.08, 0.3, 0.45, 0.1)
    kf.update(np.zeros(6))
    P1 = kf.P.copy()
    kf.R[0, 0] *= 100.0
    kf.update(np.zeros(6))
    ref = make_kf(0.01, np.zeros(3), 0.08, 0.3, 0.45, 0.1)
    ref.update(np.zeros(6))
    ref.R[0, 0] *= 100.0
    ref.update(np.zeros(6))
    assert np.array_equal(kf.P, ref.P) and not np.array_equal(kf.P, P1)
    assert kf.S[0, 0] == pytest.approx(P1[0, 0] + kf.R[0, 0])


def test_noise_rows_are_the_noise_arrays_across_blocks():
    """gyro_noise(rows=True) (a few vehicles, on floats) hands out exactly gyro_noise()'s
    numbers, step by step, also where a new block of draws begins."""
    a, b = Sensors(vehicle_rngs(5, 3)), Sensors(vehicle_rngs(5, 3))
    for _ in range(600):                     # more than two blocks of 256 steps
        assert np.array_equal(a.gyro_noise(), np.array(b.gyro_noise(rows=True)))


def test_estimator_arrays_are_built_from_its_rows():
    """After a per-vehicle epoch the arrays (pos, vel, ...) are the rows' columns; setting
    one afterwards keeps the others."""
    f = CopterFleet(2, seed=[4, 5])
    for _ in range(8):
        f.step(0.0025)
    e = f.estimator
    rows = np.array(e.rows)
    assert np.array_equal(e.pos, rows[:, 0:3]) and np.array_equal(e.quat, rows[:, 12:16])
    assert np.array_equal(e.ahrs_err, rows[:, 23:26])
    e.vel = np.ones((2, 3))
    assert np.array_equal(e.vel, np.ones((2, 3))) and np.array_equal(e.pos, rows[:, 0:3])


def test_constant_position_fusion_is_the_kalman_update_without_bias_learning():
    """vehicle.no_aiding fuses the last known position axis by axis (EKF3's sequential fusion)
    with the accelerometer-bias gains zero: with no bias cross-covariance that is filterpy's
    joint update of H = [I2 0], R = r I2; the bias never moves."""
    from filterpy.kalman import KalmanFilter

    from vehicle.no_aiding import fuse_position_ne
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 6))
    P = np.zeros((9, 9))
    P[:6, :6] = A @ A.T + np.eye(6)
    P[6:, 6:] = np.eye(3) * 0.01
    x = rng.normal(size=9)
    kf = KalmanFilter(dim_x=9, dim_z=2)
    kf.x, kf.P = x.copy(), P.copy()
    kf.H = np.hstack([np.eye(2), np.zeros((2, 7))])
    kf.R = np.eye(2) * 100.0
    kf.update(np.array([3.0, -2.0]))
    x2, P2 = x.copy(), P.copy()
    yn, ye, sn, se = fuse_position_ne(x2, P2, (3.0, -2.0), 100.0)
    np.testing.assert_allclose(x2, kf.x, atol=1e-9)
    np.testing.assert_allclose(P2, kf.P, atol=1e-9)
    assert (yn, ye, sn, se) == pytest.approx((x[0] - 3.0, x[1] + 2.0, P[0, 0] + 100.0, P[1, 1] + 100.0))
    P[0:6, 6:] = 0.005                         # now correlated with the bias: still not learned from it
    P[6:, 0:6] = 0.005
    x3 = x.copy()
    fuse_position_ne(x3, P, (3.0, -2.0), 100.0)
    assert x3[6:].tolist() == x[6:].tolist()


def test_no_aiding_stops_after_15_s_and_resumes_on_a_fix():
    """EKF3's AID_NONE: aligned and 15 s without GPS, the filter stops aiding with the
    horizontal velocity zeroed and its ratios reset; a fix resets position and velocity to it."""
    from vehicle.innovations import InnovationLog
    from vehicle.no_aiding import AIDING_LOSS_S, NoAiding
    spec = SensorSpec()
    na, log = NoAiding(1, spec), InnovationLog(1)
    log.pos[0] = log.vel[0] = 0.7
    assert not na.due(0, False, 100.0) and not na.due(0, True, AIDING_LOSS_S)
    assert na.due(0, True, AIDING_LOSS_S + 0.1)
    x, P = np.arange(9.0), np.eye(9) * 4.0 + 0.5
    na.stop(0, x, P, log)
    assert na.active == [True] and na.last_known == [(0.0, 1.0)]
    assert x[3] == x[4] == 0.0 and P[3, 3] == spec.gps_vel_sigma ** 2 and P[0, 0] == spec.gps_pos_sigma ** 2
    assert P[0, 3] == P[3, 8] == 0.0 and log.pos[0] == log.vel[0] == 0.0
    x[0] += 5.0
    na.fuse(0, x, P, log)
    assert 0.0 < x[0] < 5.0 and log.pos[0] > 0.0                  # pulled back toward (0, 1)
    na.resume(0, x, P, [10.0, 20.0, -3.0, 1.0, 2.0, 0.0])
    assert na.active == [False] and x[[0, 1, 3, 4]].tolist() == [10.0, 20.0, 1.0, 2.0]


@pytest.mark.parametrize("kind", ["filterpy", "batched"])
def test_baro_is_taken_50_ms_apart_as_ekf3_takes_it(kind):
    """EKF3 takes a height sample only when it is more than 50 ms after the last one taken
    (sensorIntervalMin_ms): of a 50 Hz baro, every third sample, 60 ms apart, for the drone's
    400 Hz steps and the rover's 50 Hz loop alike."""
    from vehicle.estimation import SENSOR_INTERVAL_MIN_MS
    for fleet, dt in ((CopterFleet(2, seed=[1, 2], estimator=kind), 0.0025),
                      (RoverFleet(2, seed=[1, 2], estimator=kind), 0.0025)):
        fused, last = [], None
        for k in range(int(1.2 / dt)):
            fleet.step(dt)
            hgt = fleet.estimator.innovations.hgt.tolist()
            if hgt != last:
                fused.append(k)
                last = hgt
        gaps = {round((b - a) * dt * 1000) for a, b in zip(fused, fused[1:])}
        assert gaps == {60} and 60 > SENSOR_INTERVAL_MIN_MS and len(fused) >= 19
