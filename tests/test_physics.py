"""Physics cores: multicopter rigid body and skid-steer rover (pure, no clocks)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from vehicle.physics import NumpyOps, ScalarOps
from vehicle.physics import multicopter as mc
from vehicle.physics import rover as rp

DT = 1.0 / 400.0


def _air(pos=(0.0, 0.0, -50.0), **kw):
    af = mc.QuadAirframe(**kw)
    s = mc.QuadState(None, pos=pos)
    s.ground = False
    return af, s


def _run(s, af, cmd, secs, ground_z=0.0):
    for _ in range(int(round(secs / DT))):
        mc.step(s, cmd, af, DT, ground_z, ScalarOps)


def test_hover_at_trimmed_throttle_holds_altitude():
    af, s = _air()
    w = mc.hover_omega(af)
    s.m0 = s.m1 = s.m2 = s.m3 = w
    _run(s, af, [w] * 4, 10.0)
    assert abs(s.pz + 50.0) < 1e-6 and abs(s.vz) < 1e-9
    assert abs(s.px) < 1e-9 and abs(s.wx) < 1e-9 and abs(s.wz) < 1e-9
    # and the trim is what the airframe says: 1.8 kg, hover thrust fraction 0.45
    assert af.mass == pytest.approx(1.8) and 4 * af.kt * w * w == pytest.approx(af.mass * mc.GRAVITY)


def test_hover_throttle_is_sensible():
    af = mc.QuadAirframe()
    assert 1.5 <= af.mass <= 2.0 and 0.4 <= af.hover_throttle <= 0.5


def test_free_fall_matches_g():
    af, s = _air(drag_lin=0.0, drag_quad=0.0)
    _run(s, af, [0.0] * 4, 1.0)
    assert s.vz == pytest.approx(mc.GRAVITY * 1.0, rel=1e-9)
    # semi-implicit Euler: within g*dt*t/2 of 0.5 g t^2
    assert abs((s.pz + 50.0) - 0.5 * mc.GRAVITY) < mc.GRAVITY * DT


def test_drag_terminal_velocity():
    af, s = _air(pos=(0.0, 0.0, -5000.0))
    _run(s, af, [0.0] * 4, 60.0)
    c1, c2, mg = af.drag_lin, af.drag_quad, af.mass * mc.GRAVITY
    vt = (-c1 + math.sqrt(c1 * c1 + 4 * c2 * mg)) / (2 * c2)
    assert s.vz == pytest.approx(vt, rel=1e-3)
    assert 10.0 < vt < 40.0


def test_ground_contact_no_sinking_and_rest():
    af, s = _air(pos=(0.0, 0.0, -2.0))
    zs = []
    for _ in range(int(3.0 / DT)):
        mc.step(s, [0.0] * 4, af, DT, 0.0, ScalarOps)
        zs.append(s.pz)
    assert max(zs) <= 0.0
    assert s.pz == 0.0 and s.vz == 0.0 and s.ground
    # friction: a sliding vehicle on the ground stops
    s.vx = 3.0
    _run(s, af, [0.0] * 4, 1.0)
    assert abs(s.vx) < 1e-3 and s.pz == 0.0


def test_ground_at_home_z_and_takeoff_releases():
    af = mc.QuadAirframe()
    s = mc.QuadState(None, pos=(0.0, 0.0, -3.0))
    _run(s, af, [0.0] * 4, 1.0, ground_z=-3.0)
    assert s.pz == -3.0 and s.ground
    full = af.omega_max
    _run(s, af, [full] * 4, 0.5, ground_z=-3.0)
    assert s.pz < -3.5 and not s.ground


def test_quaternion_stays_unit_and_integrates_rate():
    af, s = _air(ang_damp=0.0, drag_lin=0.0, drag_quad=0.0)
    rng = np.random.default_rng(1)
    for _ in range(800):
        cmd = list(rng.uniform(0.3, 1.0, 4) * af.omega_max)
        mc.step(s, cmd, af, DT, 1e9, ScalarOps)
        n = math.sqrt(s.qx ** 2 + s.qy ** 2 + s.qz ** 2 + s.qw ** 2)
        assert abs(n - 1.0) < 1e-12
    # pure yaw spin with no torque: yaw advances by w t
    af, s = _air(ang_damp=0.0)
    s.wz = 1.0
    _run(s, af, [0.0] * 4, 1.0)
    yaw = math.atan2(2 * (s.qw * s.qz + s.qx * s.qy), 1 - 2 * (s.qy ** 2 + s.qz ** 2))
    assert yaw == pytest.approx(1.0, abs=1e-9)


def test_motor_lag_time_constant():
    af, s = _air()
    target = 1000.0
    n = int(round(af.motor_tau / DT))
    _run(s, af, [target] * 4, n * DT)
    assert s.m0 / target == pytest.approx(1 - math.exp(-n * DT / af.motor_tau), rel=1e-9)
    assert s.m0 / target == pytest.approx(1 - math.exp(-1), abs=0.01)


def test_torque_signs_quad_x():
    """Right motors faster -> roll left (negative); front faster -> pitch up; CCW pair -> yaw right."""
    for cmd, axis, sign in (([900, 1000, 1000, 900], "wx", +1),   # left side (BL, FL) faster
                            ([1000, 900, 1000, 900], "wy", +1),   # front (FR, FL) faster
                            ([1000, 1000, 900, 900], "wz", +1)):  # CCW (FR, BL) faster
        af, s = _air()
        s.m0, s.m1, s.m2, s.m3 = cmd
        _run(s, af, cmd, 0.05)
        assert math.copysign(1, getattr(s, axis)) == sign


def test_numpy_and_scalar_backends_agree():
    af = mc.QuadAirframe()
    a = mc.QuadState(2, pos=np.array([[0, 0, -10.0], [1, 2, -5.0]]))
    a.ground[:] = False
    b = [mc.QuadState(None, pos=(0, 0, -10.0)), mc.QuadState(None, pos=(1, 2, -5.0))]
    cmds = [np.array([700.0, 720.0]), np.array([710.0, 690.0]), np.array([705.0, 700.0]), np.array([702.0, 730.0])]
    for _ in range(400):
        mc.step(a, cmds, af, DT, np.zeros(2), NumpyOps)
        for i in range(2):
            mc.step(b[i], [float(c[i]) for c in cmds], af, DT, 0.0, ScalarOps)
    for i in range(2):
        for f in ("px", "py", "pz", "qx", "qy", "qz", "qw", "wx"):
            assert getattr(a, f)[i] == pytest.approx(getattr(b[i], f), abs=1e-9)


class _Lim:
    max_speed = 10.0
    max_rate = 2.0


def test_rover_first_order_speed_limits_and_ground():
    m = rp.RoverModel()
    s = rp.RoverState(1)
    for _ in range(int(m.speed_tau / DT)):
        rp.step(s, np.array([1.0]), np.array([0.0]), m, _Lim, DT)
    assert s.speed[0] == pytest.approx(1 - math.exp(-1), abs=0.01)
    for _ in range(int(10 / DT)):
        rp.step(s, np.array([50.0]), np.array([9.0]), m, _Lim, DT)
    assert s.speed[0] == pytest.approx(10.0, abs=1e-6)        # speed limit
    assert s.rate[0] == pytest.approx(2.0, abs=1e-6)          # turn-rate limit
    assert s.pz[0] == 0.0 and s.vz[0] == 0.0
    assert math.hypot(s.vx[0], s.vy[0]) == pytest.approx(10.0)
    assert s.qx[0] == 0.0 and s.qz[0] ** 2 + s.qw[0] ** 2 == pytest.approx(1.0)
