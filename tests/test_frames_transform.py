"""Transform math checked against independent references: scipy Rotation and 4x4 matrices."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from common.frames import InvalidArgumentException, Transform

finite = st.floats(-100.0, 100.0, allow_nan=False, allow_infinity=False)
vec3 = st.tuples(finite, finite, finite)
angle = st.floats(-math.pi, math.pi, allow_nan=False)
settings.register_profile("frames", max_examples=150, deadline=None)
settings.load_profile("frames")


@st.composite
def quats(draw):
    q = np.array(draw(st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 4)))
    n = np.linalg.norm(q)
    assume(n > 0.1)
    return tuple(q / n)


@st.composite
def transforms(draw):
    return Transform(draw(vec3), draw(quats()))


def ref_matrix(t: Transform) -> np.ndarray:
    """4x4 built from scipy, independent of Transform's own math."""
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(np.asarray(t.rotation)).as_matrix()
    m[:3, 3] = t.translation
    return m


def same_rotation(q1, q2, atol=1e-9) -> bool:
    return abs(abs(float(np.dot(q1, q2))) - 1.0) < atol


# ---------------------------------------------------------------- construction
def test_defaults_and_identity():
    t = Transform()
    assert t == Transform.identity()
    np.testing.assert_array_equal(t.translation, [0, 0, 0])
    np.testing.assert_array_equal(t.rotation, [0, 0, 0, 1])
    np.testing.assert_array_equal(t.to_matrix(), np.eye(4))


def test_immutable_and_readonly_arrays():
    t = Transform((1, 2, 3), (0, 0, 0, 1))
    with pytest.raises(AttributeError):
        t.foo = 1
    with pytest.raises(AttributeError):
        t._v = (0,) * 7
    with pytest.raises(ValueError):
        t.translation[0] = 5.0
    with pytest.raises(ValueError):
        t.rotation[3] = 5.0
    assert t.xyz == (1.0, 2.0, 3.0) and t.xyzw == (0.0, 0.0, 0.0, 1.0)


@pytest.mark.parametrize("bad", [
    dict(translation=(math.nan, 0, 0)),
    dict(translation=(0, math.inf, 0)),
    dict(rotation=(0, 0, 0, math.nan)),
    dict(rotation=(0, 0, -math.inf, 1)),
    dict(rotation=(0, 0, 0, 1.02)),          # norm 2 % off
    dict(rotation=(0, 0, 0, 0)),
    dict(translation=(1, 2)),
    dict(rotation=(0, 0, 1)),
    dict(translation="abc"),
])
def test_invalid_construction(bad):
    with pytest.raises(InvalidArgumentException):
        Transform(**bad)


def test_norm_within_one_percent_is_normalised():
    t = Transform(rotation=(0, 0, 0, 1.009))
    assert t.rotation[3] == 1.0
    q = np.array([0.1, 0.2, 0.3, 0.9])
    q = q / np.linalg.norm(q) * 0.992
    t = Transform(rotation=q)
    assert abs(np.linalg.norm(t.rotation) - 1.0) < 1e-15


# ---------------------------------------------------------------- matrices
@given(transforms())
def test_to_matrix_matches_scipy(t):
    np.testing.assert_allclose(t.to_matrix(), ref_matrix(t), atol=1e-12)


@given(transforms())
def test_from_matrix_round_trip(t):
    back = Transform.from_matrix(ref_matrix(t))
    np.testing.assert_allclose(back.translation, t.translation, atol=1e-12)
    assert same_rotation(back.rotation, t.rotation)


def test_from_matrix_rejects_non_rotation():
    m = np.eye(4)
    m[0, 0] = -1.0  # reflection
    with pytest.raises(InvalidArgumentException):
        Transform.from_matrix(m)
    m = np.eye(4)
    m[:3, :3] *= 2.0
    with pytest.raises(InvalidArgumentException):
        Transform.from_matrix(m)
    m = np.eye(4)
    m[3, 0] = 1.0
    with pytest.raises(InvalidArgumentException):
        Transform.from_matrix(m)
    with pytest.raises(InvalidArgumentException):
        Transform.from_matrix(np.eye(3))
    m = np.eye(4)
    m[1, 3] = math.nan
    with pytest.raises(InvalidArgumentException):
        Transform.from_matrix(m)


# ---------------------------------------------------------------- algebra
@given(transforms(), transforms())
def test_compose_is_matrix_product(a, b):
    np.testing.assert_allclose((a * b).to_matrix(), ref_matrix(a) @ ref_matrix(b), atol=1e-9)


@given(transforms())
def test_inverse_is_matrix_inverse(a):
    np.testing.assert_allclose(a.inverse().to_matrix(), np.linalg.inv(ref_matrix(a)), atol=1e-9)
    assert (a * a.inverse()).almost_equal(Transform.identity(), atol=1e-9)


def test_compose_order_is_b_first():
    a = Transform((1, 0, 0))                       # translate x
    b = Transform.from_euler(yaw=math.pi / 2)    # yaw 90
    p = (1.0, 0.0, 0.0)
    np.testing.assert_allclose((a * b).apply_point(p), a.apply_point(b.apply_point(p)), atol=1e-15)
    np.testing.assert_allclose((a * b).apply_point(p), [1, 1, 0], atol=1e-15)
    assert a.__mul__(3) is NotImplemented


# ---------------------------------------------------------------- applying
@given(transforms(), vec3)
def test_apply_single(t, p):
    m = ref_matrix(t)
    np.testing.assert_allclose(t.apply_point(p), m[:3, :3] @ p + m[:3, 3], atol=1e-9)
    np.testing.assert_allclose(t.apply_vector(p), m[:3, :3] @ p, atol=1e-9)
    np.testing.assert_allclose(t.apply_point(np.array(p)), m[:3, :3] @ p + m[:3, 3], atol=1e-9)


@given(transforms(), st.integers(0, 40), st.integers(0, 2**31 - 1))
def test_apply_batched(t, n, seed):
    pts = np.random.default_rng(seed).uniform(-50, 50, (n, 3))
    r = Rotation.from_quat(np.asarray(t.rotation))
    np.testing.assert_allclose(t.apply_point(pts), r.apply(pts) + t.translation, atol=1e-9)
    np.testing.assert_allclose(t.apply_vector(pts), r.apply(pts).reshape(n, 3), atol=1e-9)
    # list input and a non-contiguous view give the same answer; input is not modified
    before = pts.copy()
    if n:  # an empty list has no shape to tell points from
        np.testing.assert_allclose(t.apply_point(pts.tolist()), r.apply(pts) + t.translation,
                                   atol=1e-9)
    view = np.hstack([pts, pts])[:, ::2]
    np.testing.assert_allclose(t.apply_point(view), Transform.apply_point(t, view.copy()))
    np.testing.assert_array_equal(pts, before)


def test_apply_3x3_list_is_three_points():
    t = Transform((1, 2, 3))
    out = t.apply_point([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_allclose(out, [[1, 2, 3], [2, 2, 3], [1, 3, 3]])


def test_apply_rejects_bad_shape():
    with pytest.raises(InvalidArgumentException):
        Transform().apply_point(np.zeros((4, 2)))
    with pytest.raises(InvalidArgumentException):
        Transform().apply_vector([1.0, 2.0])


# ---------------------------------------------------------------- euler
@given(angle, st.floats(-1.45, 1.45), angle, vec3)
def test_from_euler_matches_scipy_zyx(yaw, pitch, roll, t):
    tr = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll, translation=t)
    ref = Rotation.from_euler("ZYX", [yaw, pitch, roll])   # intrinsic Z-Y-X = Rz Ry Rx
    np.testing.assert_allclose(tr.rotation_matrix(), ref.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(tr.translation, t)
    # Rz(yaw) @ Ry(pitch) @ Rx(roll), written out
    rz = Rotation.from_rotvec([0, 0, yaw]).as_matrix()
    ry = Rotation.from_rotvec([0, pitch, 0]).as_matrix()
    rx = Rotation.from_rotvec([roll, 0, 0]).as_matrix()
    np.testing.assert_allclose(tr.rotation_matrix(), rz @ ry @ rx, atol=1e-12)


@given(angle, st.floats(-1.45, 1.45), angle)
def test_euler_round_trip(yaw, pitch, roll):
    y, p, r = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll).yaw_pitch_roll()
    back = Transform.from_euler(yaw=y, pitch=p, roll=r)
    assert back.almost_equal(Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll), atol=1e-9)
    assert abs(p - pitch) < 1e-9
    assert abs(math.remainder(y - yaw, 2 * math.pi)) < 1e-8
    assert abs(math.remainder(r - roll, 2 * math.pi)) < 1e-8


@given(transforms())
def test_yaw_pitch_roll_matches_scipy(t):
    y, p, r = t.yaw_pitch_roll()
    ref = Rotation.from_quat(np.asarray(t.rotation))
    assume(abs(math.cos(p)) > 1e-3)
    np.testing.assert_allclose(Rotation.from_euler("ZYX", [y, p, r]).as_matrix(), ref.as_matrix(),
                               atol=1e-9)


def test_yaw_pitch_roll_at_gimbal_lock_keeps_rotation():
    for pitch in (math.pi / 2, -math.pi / 2):
        t = Transform.from_euler(yaw=0.7, pitch=pitch)
        y, p, r = t.yaw_pitch_roll()
        assert r == 0.0 and abs(p - pitch) < 1e-7
        assert Transform.from_euler(yaw=y, pitch=p, roll=r).almost_equal(t, atol=1e-7)


# ---------------------------------------------------------------- yaw_only
@given(transforms())
def test_yaw_only(t):
    y = t.yaw_only()
    np.testing.assert_array_equal(y.translation, t.translation)
    yaw, pitch, roll = y.yaw_pitch_roll()
    assert abs(pitch) < 1e-12 and abs(roll) < 1e-12
    # heading of the rotated x axis' horizontal projection is kept
    x = Rotation.from_quat(np.asarray(t.rotation)).apply([1.0, 0.0, 0.0])
    h = math.hypot(x[0], x[1])
    assume(h > 1e-6)
    np.testing.assert_allclose(y.apply_vector([1.0, 0.0, 0.0]), [x[0] / h, x[1] / h, 0.0], atol=1e-9)
    assert abs(math.remainder(yaw - t.yaw_pitch_roll()[0], 2 * math.pi)) < 1e-9
    # rotation is about z only
    np.testing.assert_allclose(y.apply_vector([0.0, 0.0, 1.0]), [0, 0, 1], atol=1e-12)


def test_yaw_only_at_pitch_90_uses_roll_zero_convention():
    t = Transform.from_euler(yaw=0.4, pitch=math.pi / 2, translation=(1, 2, 3))
    y = t.yaw_only()
    assert abs(y.yaw_pitch_roll()[0] - 0.4) < 1e-7
    np.testing.assert_array_equal(y.translation, [1, 2, 3])


def test_interpolate_endpoints_and_shortest_path():
    a = Transform((0, 0, 0), Rotation.from_euler("z", 10, degrees=True).as_quat())
    b = Transform((2, 4, 6), -Rotation.from_euler("z", 30, degrees=True).as_quat())  # -q
    assert a.interpolate(b, 0.0) is a and a.interpolate(b, 1.0) is b
    m = a.interpolate(b, 0.5)
    np.testing.assert_allclose(m.translation, [1, 2, 3])
    assert abs(m.yaw_pitch_roll()[0] - math.radians(20)) < 1e-12


def test_eq_hash_repr():
    a = Transform((1, 2, 3), (0, 0, 0, 1))
    assert a == Transform((1, 2, 3)) and hash(a) == hash(Transform((1, 2, 3)))
    assert a != Transform((1, 2, 3.5))
    assert "Transform(translation=(1, 2, 3)" in repr(a)
    assert Transform(rotation=(0, 0, 0, 1)).almost_equal(Transform(rotation=(0, 0, 0, -1)))


@pytest.mark.parametrize("n", [8191, 8192, 8193, 3 * 8192 + 17, 100_000])
def test_apply_large_batches_blockwise(n):
    t = Transform.from_euler(yaw=0.3, pitch=-0.2, roll=0.1, translation=(1.0, -2.0, 3.0))
    pts = np.random.default_rng(n).uniform(-100, 100, (n, 3))
    r = Rotation.from_quat(np.asarray(t.rotation))
    np.testing.assert_allclose(t.apply_point(pts), r.apply(pts) + [1.0, -2.0, 3.0], atol=1e-9)
    np.testing.assert_allclose(t.apply_vector(pts), r.apply(pts), atol=1e-9)
    strided = np.asfortranarray(pts)
    np.testing.assert_allclose(t.apply_point(strided), r.apply(pts) + [1.0, -2.0, 3.0], atol=1e-9)
    np.testing.assert_allclose(t.apply_point(pts.astype(np.float32)),
                               r.apply(pts) + [1.0, -2.0, 3.0], atol=1e-3)


# ---- tf.transformations-style helpers: the project's one Euler and SLERP ----------------
from common.frames import euler_from_quaternion, quaternion_from_euler, quaternion_slerp  # noqa: E402


@given(quats())
def test_euler_from_quaternion_matches_scipy(q):
    roll, pitch, yaw = euler_from_quaternion(q)
    assume(abs(abs(pitch) - math.pi / 2) > 1e-3)          # away from gimbal lock
    ref_yaw, ref_pitch, ref_roll = Rotation.from_quat(q).as_euler("ZYX")
    diff = np.subtract((roll, pitch, yaw), (ref_roll, ref_pitch, ref_yaw))
    assert np.abs((diff + math.pi) % (2 * math.pi) - math.pi).max() < 1e-7   # +-pi are one angle


@given(st.floats(-math.pi, math.pi), st.floats(-1.5, 1.5), st.floats(-math.pi, math.pi))
def test_quaternion_from_euler_round_trips_and_matches_transform(roll, pitch, yaw):
    q = quaternion_from_euler(roll, pitch, yaw)
    assert same_rotation(q, Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll).xyzw)
    diff = np.subtract(euler_from_quaternion(q), (roll, pitch, yaw))
    assert np.abs((diff + math.pi) % (2 * math.pi) - math.pi).max() < 1e-7   # +-pi are one angle


def test_euler_from_quaternion_normalises_and_refuses_zero():
    assert euler_from_quaternion((0, 0, 0, 2.0)) == (0.0, 0.0, 0.0)
    with pytest.raises(InvalidArgumentException, match="Euler"):
        euler_from_quaternion((0, 0, 0, 0))


@given(quats(), quats(), st.floats(0.0, 1.0))
def test_quaternion_slerp_matches_scipy_shortest_path(a, b, s):
    assume(1e-6 < abs(float(np.dot(a, b))) < 1 - 1e-6)       # a unique shortest path: not +-b equally near
    from scipy.spatial.transform import Slerp
    b_near = b if np.dot(a, b) >= 0 else -np.asarray(b)
    ref = Slerp([0, 1], Rotation.from_quat([a, b_near]))([s]).as_quat()[0]
    assert same_rotation(quaternion_slerp(a, b, s), ref, atol=1e-7)


def test_euler_api_cannot_be_called_in_the_wrong_order():
    """from_euler is keyword-only (quaternion_from_euler takes the same angles roll-first), and
    the reader says its order in its name."""
    with pytest.raises(TypeError):
        Transform.from_euler(0.3, 0.2, 0.1)          # which is yaw? the caller must say
    t = Transform.from_euler(roll=0.1, pitch=0.2, yaw=0.3)
    assert t.yaw_pitch_roll() == pytest.approx((0.3, 0.2, 0.1))
    assert same_rotation(t.xyzw, quaternion_from_euler(0.1, 0.2, 0.3))
    assert Transform.from_euler(yaw=0.3).yaw_pitch_roll() == pytest.approx((0.3, 0.0, 0.0))
    assert not hasattr(t, "to_euler")
