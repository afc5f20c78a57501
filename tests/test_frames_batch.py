"""common.frames.batch: the batch rotation forms agree with scipy and with Transform, both paths."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from common.frames import Transform, euler_from_quaternion
from common.frames.batch import SMALL, body_z_axis, ground_point, quat_mul, rotate, wrap_pi, yaw_of

SIZES = (1, SMALL, SMALL + 1, 50)     # the float path and the numpy path, at their seam


@pytest.mark.parametrize("n", SIZES)
def test_rotate_matches_scipy(n):
    rng = np.random.default_rng(n)
    q = Rotation.random(n, random_state=n).as_quat()
    v = rng.normal(size=(n, 3))
    assert np.allclose(rotate(q, v), Rotation.from_quat(q).apply(v), atol=1e-12)
    assert np.allclose(rotate(q, v, inverse=True), Rotation.from_quat(q).inv().apply(v), atol=1e-12)


@pytest.mark.parametrize("n", SIZES)
def test_quat_mul_is_composition(n):
    a = Rotation.random(n, random_state=n)
    b = Rotation.random(n, random_state=n + 100)
    got = Rotation.from_quat(quat_mul(a.as_quat(), b.as_quat()))
    assert np.allclose(got.as_matrix(), (a * b).as_matrix(), atol=1e-12)   # apply b, then a


def test_body_z_axis_is_the_third_column():
    r = Rotation.random(20, random_state=3)
    assert np.allclose(body_z_axis(r.as_quat()), r.as_matrix()[:, :, 2], atol=1e-12)
    assert body_z_axis([0.0, 0.0, 0.0, 1.0]).tolist() == [0.0, 0.0, 1.0]


@given(st.floats(-3.1, 3.1), st.floats(-1.5, 1.5), st.floats(-3.1, 3.1))
def test_yaw_of_floats_and_arrays_equal_euler_yaw(yaw, pitch, roll):
    q = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll).rotation
    assert yaw_of(*q, atan2=math.atan2) == pytest.approx(euler_from_quaternion(q)[2], abs=1e-9)
    arr = np.array([q, q])
    assert np.allclose(yaw_of(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3]), yaw, atol=1e-9)


@given(st.floats(-1e4, 1e4))
def test_wrap_pi(a):
    w = wrap_pi(a)
    assert -math.pi <= w < math.pi
    assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-9)
    assert math.cos(w) == pytest.approx(math.cos(a), abs=1e-9)
    assert wrap_pi(np.array([a, math.pi])).tolist()[1] == pytest.approx(-math.pi)


@settings(max_examples=50)
@given(st.floats(-3.1, 3.1), st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(1.0, 50.0),
       st.floats(-5, 5), st.floats(-5, 5))
def test_ground_point_is_the_frame_applied_to_the_point_below(yaw, pitch, roll, h, ox, oy):
    T = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll, translation=(3.0, -4.0, -h))
    want = T.apply_point([ox, oy, h])[:2]
    assert ground_point(T.translation, T.rotation, h, (ox, oy)) == pytest.approx(want, abs=1e-9)
    # the wobble: with no offset the point is h·sin(tilt) from under the frame's origin
    # body z = Rz Ry Rx e_z; its horizontal part (cos r sin p, -sin r) is sin(tilt) long
    sin_tilt = math.hypot(math.cos(roll) * math.sin(pitch), math.sin(roll))
    gp = ground_point(T.translation, T.rotation, h)
    assert math.hypot(gp[0] - 3.0, gp[1] + 4.0) == pytest.approx(h * sin_tilt, abs=1e-9)
    # batched over leading dimensions
    many = ground_point(np.array([T.translation] * 3), np.array([T.rotation] * 3), np.full(3, h), (ox, oy))
    assert many.shape == (3, 2) and np.allclose(many, want, atol=1e-9)
