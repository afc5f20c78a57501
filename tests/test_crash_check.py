"""ArduCopter's crash check (vehicle/autopilot/crash_check.py) and the failsafe LAND's pause
(copter_modes/land.py, copter_failsafe.land_with_pause) against ArduCopter's crash_check.cpp,
events.cpp and mode_land.cpp: the pure parts, then in-process on the real World (physics,
sensors, estimator, autopilot) in sim time."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given
from hypothesis import strategies as st
from test_autopilot_behaviour import A, _fly, _until, _world

from vehicle.autopilot import crash_check, modes
from vehicle.autopilot.copter_modes.land import LAND_WITH_DELAY_S
from vehicle.autopilot.guided import ACC_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE
from vehicle.fleet import CopterFleet, Setpoint
from vehicle.logs import messages
from vehicle.physics import ScalarOps
from vehicle.physics import multicopter as mc


def _quat(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


# ---------------------------------------------------------------- pure parts

@given(lean=st.floats(0.0, math.pi), yaw=st.floats(-3.1, 3.1))
@example(lean=math.pi, yaw=0.34340289475812025)      # upside down: rounding past -1
def test_lean_and_error_angles(lean, yaw):
    """lean_cos is cos of the lean from level, whatever the heading; error_angle_deg turns
    the controller's att_err (sin^2 of half the angle) back into degrees."""
    q = _quat(lean, 0.0, yaw) if lean <= math.pi / 2 else _quat(math.pi, math.pi - lean, yaw)
    assert math.degrees(math.acos(crash_check.lean_cos(q))) == pytest.approx(math.degrees(lean), abs=1e-3)
    assert crash_check.error_angle_deg(math.sin(lean / 2) ** 2) == pytest.approx(math.degrees(lean), abs=1e-3)


def test_thresholds_are_crash_check_cpp():
    assert (crash_check.TRIGGER_SEC, crash_check.ANGLE_DEVIATION_DEG, crash_check.ANGLE_MIN_DEG,
            crash_check.SPEED_MAX, crash_check.ACCEL_MAX) == (2.0, 30.0, 15.0, 10.0, 3.0)
    assert messages.disarm_method("crash") == 12          # AP_Arming::Method::CRASH


def test_a_copter_down_on_its_side_stays_there_a_level_one_is_levelled():
    """Ground contact levels a copter that comes down nearly level (every landing); one past
    TIP_OVER_DEG lies as it fell whatever its motors do."""
    af = mc.QuadAirframe()
    for lean, kept in ((math.radians(20), False), (math.radians(80), True)):
        s = mc.QuadState(None, pos=[0.0, 0.0, -0.01], yaw=0.3)
        s.qx, s.qy, s.qz, s.qw = _quat(lean, 0.0, 0.3)
        s.ground = False
        s.vz = 2.0
        for _ in range(400):
            mc.step(s, [0.5 * af.omega_max, 0.0, 0.5 * af.omega_max, 0.5 * af.omega_max], af, 1 / 400, 0.0,
                    ScalarOps)
        assert s.ground and s.pz == 0.0
        got = math.acos(crash_check.lean_cos((s.qx, s.qy, s.qz, s.qw)))
        assert got == pytest.approx(lean if kept else 0.0, abs=1e-4)   # (kept: as at the first contact)


def test_tipping_over_is_the_same_in_the_batched_physics():
    """The numpy form (big fleets) keeps a tipped copter and levels a level one exactly as the
    scalar form does, vehicle by vehicle."""
    af = mc.QuadAirframe()
    leans = (math.radians(20), math.radians(80))
    cmd = [0.5 * af.omega_max, 0.0, 0.5 * af.omega_max, 0.5 * af.omega_max]
    v = mc.QuadState(2, pos=np.array([[0.0, 0.0, -0.01]] * 2), yaw=np.array([0.3, 0.3]))
    v.ground[:] = False
    v.vz[:] = 2.0
    for k, lean in enumerate(leans):
        v.qx[k], v.qy[k], v.qz[k], v.qw[k] = _quat(lean, 0.0, 0.3)
    scalars = []
    for lean in leans:
        s = mc.QuadState(None, pos=[0.0, 0.0, -0.01], yaw=0.3)
        s.qx, s.qy, s.qz, s.qw = _quat(lean, 0.0, 0.3)
        s.ground, s.vz = False, 2.0
        scalars.append(s)
    for _ in range(200):
        mc.step(v, [np.full(2, c) for c in cmd], af, 1 / 400, np.zeros(2))
        for s in scalars:
            mc.step(s, cmd, af, 1 / 400, 0.0, ScalarOps)
    for k, s in enumerate(scalars):
        assert (v.qx[k], v.qy[k], v.qz[k], v.qw[k]) == pytest.approx((s.qx, s.qy, s.qz, s.qw), abs=1e-9)
    assert v.qx[0] == 0.0 and abs(v.qx[1]) > 0.4


@pytest.mark.parametrize("scalar", [True, False])
def test_controller_row_reads_what_controller_of_copies(scalar):
    f = CopterFleet(3, estimator=False, scalar=scalar)
    for i in range(3):
        f.set_armed(i, True)
        f.set_setpoint(i, Setpoint(pos=[1.0 * i, 0.0, -5.0]))
    for _ in range(200):
        f.step(1 / 400)
    for i in range(3):
        row, full = crash_check.controller_row(f, i), f.controller_of(i)
        for name in ("coll", "tan_roll_t", "tan_pitch_t", "att_err", "lax", "lay", "laz", "f0", "f1", "f2", "f3"):
            assert getattr(row, name) == getattr(full, name)
        assert 0.0 < row.f0 <= 1.0


# ---------------------------------------------------------------- the World, in sim time

def _texts(w, ap):
    out = []
    ap.outbox.subscribe(text=lambda sev, t: out.append((w.t, sev, t)))
    return out


def _set(ap, **values):
    for k, v in values.items():
        ap.params.set(k, v)
    ap.push_params(values)


def _dead_motor(**params):
    """A drone 10 m up in GUIDED whose motor 1 then stops (SIM_ENGINE_FAIL 1, SIM_ENGINE_MUL's
    default 0): (world, autopilot, texts, sim s it hit the ground)."""
    w = _world()
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    _fly(w, 10.0)
    _set(ap, SIM_ENGINE_FAIL=1, **params)
    fleet = w.fleets[0][1]
    _until(w, lambda: fleet.pos[0][2] > -0.01, 10)
    return w, ap, texts, w.t


def test_a_dead_motor_crashes_and_the_crash_check_disarms():
    """The quad rolls over and hits the ground on its side, armed, its motors still driven;
    once it lies still, leaning, far off its attitude target for 2 s: EMERGENCY "Crash:
    Disarming: AngErr=..>30, Accel=..<3.0", then disarmed (reason crash)."""
    w, ap, texts, down = _dead_motor()
    assert ap.armed
    _until(w, lambda: not ap.armed, 10)
    said = [(t, sev, s) for t, sev, s in texts if s.startswith("Crash: Disarming")]
    assert len(said) == 1
    t, sev, s = said[0]
    assert sev == A.MAV_SEVERITY_EMERGENCY
    assert s.startswith("Crash: Disarming: AngErr=") and s.endswith(">30, Accel=" + s.split("Accel=")[1])
    ang, acc = float(s.split("AngErr=")[1].split(">")[0]), float(s.split("Accel=")[1].split("<")[0])
    assert ang > 30 and acc < 3.0 and s.endswith("<3.0")
    assert crash_check.TRIGGER_SEC <= t - down <= crash_check.TRIGGER_SEC + 4.0
    assert (t, A.MAV_SEVERITY_INFO, "Disarming motors: crash") in texts
    assert len(s) <= 50                                     # one STATUSTEXT


@pytest.mark.parametrize("enabled", [1, 0])
def test_fs_crash_check_0_leaves_the_wreck_armed(enabled):
    """Without the EKF failsafe (its LAND would disarm the wreck once the land detector calls
    it landed), the crash check alone decides: FS_CRASH_CHECK 0 leaves it armed in GUIDED."""
    w, ap, texts, _ = _dead_motor(FS_CRASH_CHECK=enabled, FS_EKF_THRESH=0)
    w.run_for(8.0)
    crashed = any(s.startswith("Crash: Disarming") for _, _, s in texts)
    assert (ap.armed, crashed) == ((False, True) if enabled else (True, False))
    assert ap.mode == modes.GUIDED


@pytest.mark.parametrize("mul, lost", [(0.5, True), (0.9, False)])
def test_a_weak_motor_is_a_potential_thrust_loss_not_a_crash(mul, lost):
    """SIM_ENGINE_MUL 0.5 on motor 1: the quad keeps its attitude but sinks at full throttle:
    after 1 s of that EMERGENCY "Potential Thrust Loss (1)" (the motor commanded hardest), once;
    it comes down level and is no crash. At 0.9 it flies and nothing is said."""
    w = _world()
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    _fly(w, 10.0)
    _set(ap, SIM_ENGINE_FAIL=1, SIM_ENGINE_MUL=mul)
    t0 = w.t
    w.run_for(8.0)
    said = [(t, sev, s) for t, sev, s in texts if s.startswith("Potential Thrust Loss")]
    if not lost:
        assert said == [] and ap.pos[2] < -8.0
        return
    assert [(sev, s) for _, sev, s in said] == [(A.MAV_SEVERITY_EMERGENCY, "Potential Thrust Loss (1)")]
    assert crash_check.THRUST_LOSS_TRIGGER_SEC < said[0][0] - t0 < 3.0
    assert ap.armed and not any(s.startswith("Crash") for _, _, s in texts)


def test_aggressive_flying_never_trips_it():
    """Fast GUIDED dashes with sharp reversals (20 m/s, 5 m/s/s) and an attitude target
    flip from 45 deg left to 45 deg right: the counter never starts."""
    w = _world()
    ap = w.vehicles[0].ap
    texts = _texts(w, ap)
    _fly(w, 15.0)
    _set(ap, WPNAV_SPEED=2000, WPNAV_ACCEL=500)
    worst = []
    for x in (40.0, -40.0, 40.0, 0.0):
        local = ap.local_origin.to_local((x, 0.0, -15.0))
        mask = VEL_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE
        assert ap.position_target_local(A.MAV_FRAME_LOCAL_NED, mask, tuple(local), (0, 0, 0), (0, 0, 0), 0, 0)
        for _ in range(150):
            w.run_for(0.04)
            worst.append(ap.crash_check.crashing_s)
    for roll in (45.0, -45.0, 45.0, 0.0):
        q = _quat(math.radians(roll), 0.0, 0.0)
        ap.attitude_target(0b00000111, (q[3], q[0], q[1], q[2]), (0.0, 0.0, 0.0), 0.5)
        for _ in range(25):
            w.run_for(0.04)
            worst.append(ap.crash_check.crashing_s)
    assert ap.armed and max(worst) == 0.0
    assert not any(s.startswith(("Crash", "Potential Thrust Loss")) for _, _, s in texts)


def test_a_failsafe_land_holds_its_altitude_for_the_pause_then_descends():
    """FS_GCS_ENABLE 5 (LAND): ArduCopter's set_mode_land_with_pause holds the altitude
    LAND_WITH_DELAY_MS (4 s) after LAND starts, then descends."""
    w = _world()
    ap = _fly(w, alt=10.0)               # hovering in GUIDED (LOITER would sink: the receiver's throttle is low)
    w.run_for(2.0)
    for name, v in (("FS_GCS_ENABLE", 5), ("FS_GCS_TIMEOUT", 2)):
        assert ap.params.set(name, v, save=False) is None
    ap.gcs_heartbeat()
    _until(w, lambda: ap.mode == modes.LAND, 5)
    t0, z0 = w.t, float(ap.pos[2])
    zs = []
    while w.t - t0 < LAND_WITH_DELAY_S - 0.1:
        w.run_for(0.1)
        zs.append(float(ap.pos[2]))
    assert max(abs(z - z0) for z in zs) < 0.3
    w.run_for(3.0)
    assert ap.pos[2] > z0 + 1.0                      # descending
    assert not ap.flightmode.land_pause


def test_land_by_command_and_the_fence_do_not_pause():
    """Only the failsafes pause: a LAND asked for descends at once."""
    w = _world()
    ap = _fly(w, alt=10.0)
    assert ap.set_mode(modes.LAND)
    z0 = float(ap.pos[2])
    w.run_for(3.0)
    assert ap.pos[2] > z0 + 0.6 and not ap.flightmode.land_pause       # LAND_SPEED from the start


def test_a_failsafe_finding_land_pauses_what_is_left_of_the_delay():
    """set_mode_land_with_pause when LAND is current: no new start, the pause runs out
    LAND_WITH_DELAY_S after LAND was entered (ModeLand's land_start_time)."""
    w = _world()
    ap = _fly(w, alt=10.0)
    assert ap.set_mode(modes.LAND)
    w.run_for(3.0)
    ap.failsafe.land_with_pause("EKF failsafe")
    land = ap.flightmode
    assert land.land_pause
    w.run_for(0.5)                                   # braking from LAND_SPEED
    z = float(ap.pos[2])
    w.run_for(0.4)
    assert land.land_pause and abs(ap.pos[2] - z) < 0.1      # held where it stopped
    w.run_for(0.3)
    assert not land.land_pause
    assert np.isnan(land.ap.fleet.setpoints[0].pos[2])
