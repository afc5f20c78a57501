"""ArduPilot SITL's injected faults (vehicle/sim_faults.py) and the failsafes that answer them
(vehicle/autopilot/ekf_failsafe.py), against ArduPilot's documented outcome: the pure cores,
then in-process on the real World (fleet physics, sensors, estimator, autopilot) in sim time."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from common.geo import LATLON_TO_M
from auto_world import hover_stick
from test_autopilot_behaviour import A, _fly, _until, _world
from vehicle import sim_faults
from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.land import LAND_WITH_DELAY_S
from vehicle.autopilot.ekf_failsafe import copter_over_threshold, rover_over_threshold
from vehicle.autopilot.params_ardupilot import COPTER_EXTRA
from vehicle.sensors import Sensors, SensorSpec, vehicle_rngs
from vehicle.telemetry.ekf_status import (ATTITUDE, CONST_POS, GPS_GLITCHING, POS_ABS, POS_VERT, VEL_VERT,
                                          EkfTelemetry)


# ---------------------------------------------------------------- pure cores

def test_defaults_are_no_fault_and_the_old_gps_name_is_gone():
    names = {d.name for d in COPTER_EXTRA}
    assert sim_faults.NAMES <= names
    assert "SIM_GPS_DISABLE" not in names          # ArduPilot 4.5: "1 was GPS_DISABLE"
    f = sim_faults.SimFaults.from_params({}, 51.0)
    assert f == sim_faults.NONE and f.sensors_ok and f.motors_ok and f.gps_fix


@given(x=st.floats(-1e-3, 1e-3), y=st.floats(-1e-3, 1e-3), z=st.floats(-50, 50), lat=st.floats(-80, 80))
def test_glitch_is_degrees_of_latitude_and_longitude_and_metres_up(x, y, z, lat):
    f = sim_faults.SimFaults.from_params({"SIM_GPS1_GLTCH_X": x, "SIM_GPS1_GLTCH_Y": y, "SIM_GPS1_GLTCH_Z": z}, lat)
    n, e, d = f.gps_offset
    assert n == pytest.approx(x * LATLON_TO_M)
    assert e == pytest.approx(y * LATLON_TO_M * math.cos(math.radians(lat)))
    assert d == -z


def test_engine_fail_masks_motors_with_engine_mul():
    f = sim_faults.SimFaults.from_params({"SIM_ENGINE_FAIL": 0b0101, "SIM_ENGINE_MUL": 0.3}, 0.0)
    assert f.motor_mul == (0.3, 1.0, 0.3, 1.0)
    assert sim_faults.SimFaults.from_params({"SIM_ENGINE_FAIL": 1}, 0.0).motor_mul[0] == 0.0   # MUL's default 0


@pytest.mark.parametrize("vel, pos, mag, over", [
    (0.5, 0.5, 0.5, False),          # all under
    (1.6, 0.0, 0.0, True),           # velocity at twice the threshold counts 2
    (0.8, 0.0, 0.0, False),          # velocity alone at the threshold counts 1
    (0.8, 0.8, 0.0, True),           # position with a count of 1
    (0.0, 0.8, 0.8, True),           # position and compass
    (0.0, 5.0, 0.0, False),          # position alone is not enough
    (0.8, 0.0, 0.8, True),           # velocity and compass count 2
])
def test_copter_over_threshold_is_ekf_check_cpp(vel, pos, mag, over):
    assert copter_over_threshold(vel, pos, mag, 0.8) is over


def test_rover_counts_velocity_twice_as_ardurover_does():
    assert rover_over_threshold(0.8, 0.0, 0.0, 0.8)          # 1 + 1 from its second test
    assert not rover_over_threshold(0.0, 0.8, 0.0, 0.8)


@settings(max_examples=10, deadline=None)
@given(rnd=st.floats(0.0, 3.0))
def test_baro_rnd_sets_the_baro_spread(rnd):
    """SIM_BARO_RND is the baro's 1-sigma noise (m): the readings' spread follows it."""
    n = 2000
    s = Sensors(vehicle_rngs(3, 1), SensorSpec())
    s.set_faults([sim_faults.SimFaults.from_params({"SIM_BARO_RND": rnd}, 0.0)])
    zero = [[0.0, 0.0, -10.0]]
    alts = [s.sample_rows(False, True, zero, [[0.0] * 3], [[0.0] * 3], [[0, 0, 0, 1.0]])[4][0] for _ in range(n)]
    assert np.std(alts) == pytest.approx(rnd, abs=0.05 + 0.06 * rnd)
    assert np.mean(alts) == pytest.approx(10.0, abs=0.1 + 0.1 * rnd)


def test_acc_and_gyr_rnd_widen_the_imu_spread():
    spec = SensorSpec()
    out = {}
    for rnd in (0.0, 1.0):
        s = Sensors(vehicle_rngs(5, 1), spec)
        s.set_faults([sim_faults.SimFaults.from_params({"SIM_ACC1_RND": rnd, "SIM_GYR1_RND": 10 * rnd}, 0.0)])
        acc = [s.sample_rows(False, False, [[0.0] * 3], [[0.0] * 3], [[0.0] * 3], [[0, 0, 0, 1.0]])[1][0][0]
               for _ in range(2000)]
        gyr = [s.gyro_noise(rows=k % 2 == 1)[0][0] for k in range(2000)]   # both forms (the scalar store's rows)
        out[rnd] = (np.std(acc), np.std(gyr))
    assert out[0.0][0] == pytest.approx(spec.accel_sigma, rel=0.1)
    assert out[1.0][0] == pytest.approx(math.hypot(spec.accel_sigma, 1.0), rel=0.1)
    assert out[1.0][1] == pytest.approx(math.hypot(spec.gyro_sigma, math.radians(10)), rel=0.1)


def test_gps_off_gives_no_reading_and_baro_disable_none():
    s = Sensors(vehicle_rngs(1, 2), SensorSpec())
    s.set_faults([sim_faults.SimFaults.from_params({"SIM_GPS1_ENABLE": 0, "SIM_BARO_DISABLE": 1}, 0.0),
                  sim_faults.NONE])
    row = [[0.0] * 3] * 2
    _, _, gp, gv, baro = s.sample_rows(True, True, row, row, row, [[0, 0, 0, 1.0]] * 2)
    assert gp[0] is None and gv[0] is None and baro[0] is None
    assert gp[1] is not None and baro[1] is not None
    assert s.gps_reading(0) is None and s.gps_reading(1) is not None


# ---------------------------------------------------------------- the World, in sim time

def _texts(w, ap):
    out = []
    ap.outbox.subscribe(text=lambda sev, t: out.append((w.t, t)))
    return out


def _set(ap, **values):
    """A PARAM_SET as the link makes it: stored, then pushed to the world."""
    for k, v in values.items():
        ap.params.set(k, v)
    ap.push_params(values)


def _said(texts, what):
    return next((t for t, s in texts if s == what), None)


def _loitering():
    """A drone in LOITER 10 m up: (world, autopilot, its texts, its EKF_STATUS_REPORT source)."""
    w = _world()
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    _fly(w, 10.0)
    hover_stick(ap)
    assert ap.set_mode(modes.LOITER)
    w.run_for(2.0)
    return w, ap, texts, EkfTelemetry(ap)


def test_gps_off_in_loiter_takes_the_ekf_failsafe_to_land():
    """ArduCopter: without GPS the EKF loses its position (EKF_STATUS_REPORT's position flags
    clear), the EKF check fails for 1 s, says "EKF variance" and LOITER (needs position)
    changes to LAND: "EKF Failsafe: changed to LAND Mode"; LAND (set_mode_land_with_pause)
    holds its altitude LAND_WITH_DELAY_MS, then descends without GPS."""
    w, ap, texts, health = _loitering()
    _set(ap, SIM_GPS1_ENABLE=0)
    t0 = w.t
    lost = _until(w, lambda: not health.status()[0] & POS_ABS, 15)
    assert _said(texts, "EKF variance") is None              # the flags showed it first
    _until(w, lambda: ap.mode == modes.LAND, 5)
    fs = _said(texts, "EKF variance")
    assert fs is not None and 0.9 <= fs - (t0 + lost) <= 1.3  # 10 failing checks at 10 Hz
    assert _said(texts, "EKF Failsafe: changed to LAND Mode") == fs
    z0 = w.fleets[0][1].pos[0][2]
    w.run_for(3.5)
    assert abs(w.fleets[0][1].pos[0][2] - z0) < 0.5          # the failsafe's pause (4 s)
    w.run_for(3.5)
    assert w.fleets[0][1].pos[0][2] > z0 + 1.0               # descending without a position


def test_gps_off_in_loiter_lands_and_disarms_within_the_descent_time():
    """After the EKF failsafe's LAND the copter without GPS lands and disarms, as ArduCopter:
    its filter stops aiding after 15 s and fuses the last known position (EKF3's AID_NONE:
    EKF_STATUS_REPORT attitude, vertical velocity and position, CONST_POS_MODE, velocity ratio
    0, a small position ratio) so its velocity estimate stays bounded; the land detector needs
    no horizontal stillness. Bounds: the failsafe LAND's pause (LAND_WITH_DELAY_MS), the
    descent at LAND_SPEED from the height LAND started at (below LAND_ALT_LOW, so all at
    LAND_SPEED), plus LAND_DETECT_TIME, plus 2 s for the
    vertical loop to reach the descent rate and settle at touch-down. The horizontal drift
    (LAND flies level on the attitude estimate, with no position) at most what the speed at
    LAND's start and the AHRS model's RMS tilt error (SensorSpec.ahrs_sigma on each of two
    axes) held for the whole descent, undamped, would give: v0 T + g tan(sqrt(2) sigma) T^2 / 2."""
    w, ap, texts, health = _loitering()
    fleet = w.fleets[0][1]
    _set(ap, SIM_GPS1_ENABLE=0)
    _until(w, lambda: ap.mode == modes.LAND, 15)
    start, v0 = fleet.pos[0].copy(), math.hypot(*fleet.vel[0][:2])
    height = fleet.ground_z[0] - start[2]
    assert height < ap.params.get("LAND_ALT_LOW", 1000) / 100
    bound = (LAND_WITH_DELAY_S + height / (ap.params.get("LAND_SPEED", 50) / 100)
             + fleet.gains_of(0).land_time + 2.0)
    top_speed = 0.0

    def disarmed():
        nonlocal top_speed
        top_speed = max(top_speed, math.hypot(*fleet.estimate(0).vel[:2]))
        return not ap.armed

    took = _until(w, disarmed, bound)
    assert _said(texts, "Disarming motors: landed") is not None
    assert fleet.pos[0][2] == fleet.ground_z[0] and fleet.landed(0)
    sigma = fleet.spec.ahrs_sigma * math.sqrt(2.0)          # rad
    drift = math.hypot(*(fleet.pos[0][:2] - start[:2]))
    assert drift < v0 * took + 0.5 * 9.80665 * math.tan(sigma) * took ** 2
    assert top_speed < 1.0                      # dead reckoning alone passed 2 m/s here
    flags, vel, pos, _, _ = health.status()
    assert flags == ATTITUDE | VEL_VERT | POS_VERT | CONST_POS
    assert vel == 0.0 and 0.0 < pos < 0.5


def test_gps_glitch_is_seen_and_cleared():
    """A 22 m step (SIM_GPS1_GLTCH_X 0.0002 deg): the position variance rises and the GPS
    position fails its gate ("GPS Glitch"); the filter follows the new fixes and says
    "GPS Glitch cleared"."""
    w, ap, texts, health = _loitering()
    before = health.status()[2]
    _set(ap, SIM_GPS1_GLTCH_X=0.0002)
    _until(w, lambda: _said(texts, "GPS Glitch") is not None, 2)
    assert health.status()[2] > 1.0 > before
    assert health.status()[0] & GPS_GLITCHING
    _until(w, lambda: _said(texts, "GPS Glitch cleared") is not None, 30)
    assert not health.status()[0] & GPS_GLITCHING


def test_dead_motor_the_quad_falls_and_loses_attitude():
    """SIM_ENGINE_FAIL 1 with SIM_ENGINE_MUL's default 0: motor 1 gives no thrust; a quad
    cannot fly on three: it rolls over and falls."""
    w = _world()
    ap = w.vehicles[0].ap
    _fly(w, 10.0)
    fleet = w.fleets[0][1]
    _set(ap, SIM_ENGINE_FAIL=1)
    w.run_for(1.0)
    roll, pitch, _ = fleet.truth(0).euler
    assert max(abs(roll), abs(pitch)) > math.radians(45)
    _until(w, lambda: fleet.pos[0][2] > -0.1, 5)          # on the ground within seconds
    assert fleet.motor_outputs(0)[0] == pytest.approx(0.0, abs=1e-6)


def test_weak_motor_still_flies():
    w = _world()
    ap = w.vehicles[0].ap
    _fly(w, 10.0)
    _set(ap, SIM_ENGINE_FAIL=1, SIM_ENGINE_MUL=0.9)
    w.run_for(5.0)
    assert w.fleets[0][1].pos[0][2] == pytest.approx(-10.0, abs=1.0)


def test_no_gps_fix_refuses_arming_with_bad_fix():
    """AP_Arming::gps_checks: "PreArm: GPS 1: Bad fix" without a 3D fix."""
    w = _world()
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    _set(ap, SIM_GPS1_ENABLE=0)
    assert ap.set_mode(modes.GUIDED)
    assert ap.arm() == A.MAV_RESULT_FAILED
    assert _said(texts, "PreArm: GPS 1: Bad fix") is not None
    _set(ap, SIM_GPS1_ENABLE=1)
    _until(w, lambda: ap.prearm_ok(), 10)
    assert ap.arm() == A.MAV_RESULT_ACCEPTED


def test_rover_gps_off_holds():
    """ArduRover: FS_EKF_ACTION 1 (default) -> HOLD and "EKF failsafe"; GPS back, the EKF
    recovers: "EKF failsafe cleared"."""
    w = _world(drones=0, rovers=1)
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    assert ap.set_mode(modes.ROVER_GUIDED) and ap.arm() == A.MAV_RESULT_ACCEPTED
    w.run_for(1.0)
    _set(ap, SIM_GPS1_ENABLE=0)
    _until(w, lambda: _said(texts, "EKF failsafe") is not None, 15)
    assert ap.mode == modes.ROVER_HOLD
    _set(ap, SIM_GPS1_ENABLE=1)
    _until(w, lambda: _said(texts, "EKF failsafe cleared") is not None, 15)


def test_faults_off_change_nothing():
    """Setting the SIM_* to their defaults leaves the sensors' numbers exactly as they were."""
    runs = []
    for touch in (False, True):
        w = _world()
        if touch:
            _set(w.vehicles[0].ap, **sim_faults.DEFAULTS)
        w.run_for(2.0)
        runs.append(w.fleets[0][1].est_pos.tolist())
    assert runs[0] == runs[1]


def test_fs_ekf_action_2_holds_altitude_and_gps_back_clears():
    """FS_EKF_ACTION 2: ALT_HOLD instead of LAND; GPS back, the checks pass for 1 s: "EKF
    Failsafe Cleared" (the mode stays: ArduCopter does not switch back)."""
    w, ap, texts, _ = _loitering()
    _set(ap, FS_EKF_ACTION=2, SIM_GPS1_ENABLE=0)
    _until(w, lambda: _said(texts, "EKF Failsafe: changed to ALT_HOLD Mode") is not None, 15)
    assert ap.mode == modes.ALT_HOLD
    _set(ap, SIM_GPS1_ENABLE=1)
    _until(w, lambda: _said(texts, "EKF Failsafe Cleared") is not None, 15)
    assert ap.mode == modes.ALT_HOLD


def test_fs_ekf_thresh_0_disables_the_check():
    w, ap, texts, _ = _loitering()
    _set(ap, FS_EKF_THRESH=0, SIM_GPS1_ENABLE=0)
    w.run_for(12.0)
    assert ap.mode == modes.LOITER and not ap.est_ok
    assert _said(texts, "EKF variance") is None


@given(v=st.floats(-5, 5), r=st.floats(-2, 2))
def test_skid_mix_is_identity_without_a_fault_and_a_dead_left_side_turns_left(v, r):
    assert sim_faults.skid_mix(v, r, 1.0, 1.0, 5.0, 2.0) == pytest.approx((v, r))
    v2, r2 = sim_faults.skid_mix(v, 0.0, 0.0, 1.0, 5.0, 2.0)    # straight ahead on the right side alone
    assert v2 == pytest.approx(v / 2) and r2 == pytest.approx(-v / 2 * 2.0 / 5.0)


def test_rover_with_a_dead_left_motor_veers_left():
    """SIM_ENGINE_FAIL 1 on a skid-steer rover (servo 1: the left throttle): told to drive north,
    it pivots about its dead side, to the left (yaw falls), and gets nowhere straight."""
    from vehicle.fleet import RoverFleet, Setpoint
    ends = []
    for fault in (sim_faults.NONE, sim_faults.SimFaults.from_params({"SIM_ENGINE_FAIL": 1}, 0.0)):
        f = RoverFleet(1, estimator=False)
        f.set_faults(0, fault)
        f.set_armed(0, True)
        f.set_setpoint(0, Setpoint(vel=[2.0, 0.0, 0.0]))
        for _ in range(400):
            f.step(1 / 400)
        ends.append((f.pos[0].copy(), f.truth(0).yaw))
    (ok_pos, ok_yaw), (bad_pos, bad_yaw) = ends
    assert ok_pos[0] > 1.0 and abs(ok_yaw) < 0.05
    assert bad_pos[0] < 0.8 * ok_pos[0] and bad_yaw < -0.1


@pytest.mark.parametrize("estimator", ["filterpy", "batched"])
def test_one_vehicles_gps_fault_leaves_the_others_alone(estimator):
    """Per-vehicle filters and the batched one alike: vehicle 1 without GPS loses its position
    after the EKF's 7 s and is not corrected, vehicle 2's glitch moves its estimate by the step,
    vehicle 0 is as it was."""
    from vehicle.fleet import CopterFleet
    n = 3
    home = np.array([[0.0, 2.0 * i, 0.0] for i in range(n)])
    runs = {}
    for faulty in (False, True):
        f = CopterFleet(n, seed=2, home=home, estimator=estimator)
        for _ in range(400 * 3):
            f.step(1 / 400)
        assert all(f.estimate_ok(i) for i in range(n))
        if faulty:
            f.set_faults(1, sim_faults.SimFaults.from_params({"SIM_GPS1_ENABLE": 0}, 0.0))
            f.set_faults(2, sim_faults.SimFaults.from_params({"SIM_GPS1_GLTCH_X": 1e-4}, 0.0))
        for _ in range(400 * 8):
            f.step(1 / 400)
        runs[faulty] = (f.est_pos.copy(), [f.estimate_ok(i) for i in range(n)])
    (clean, ok_clean), (est, ok) = runs[False], runs[True]
    assert ok_clean == [True] * n and ok == [True, False, True]
    assert est[0].tolist() == clean[0].tolist()
    assert est[2][0] - clean[2][0] == pytest.approx(1e-4 * LATLON_TO_M, abs=1.0)    # at rest: the estimate follows the step north
