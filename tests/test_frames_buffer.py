"""Buffer semantics against independent math (4x4 matrices, scipy Slerp)."""
from __future__ import annotations

import math
import random

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation, Slerp

from common.frames import (LATEST, Buffer, FutureExtrapolationException, PastExtrapolationException,
                           PointStamped, PoseStamped, Transform, TransformStamped, VectorStamped)

from frames_reference import reference_lookup

settings.register_profile("frames", max_examples=150, deadline=None)
settings.load_profile("frames")


def rand_tf(rng: random.Random, scale: float = 10.0) -> Transform:
    q = [rng.gauss(0, 1) for _ in range(4)]
    n = math.sqrt(sum(x * x for x in q))
    return Transform([rng.uniform(-scale, scale) for _ in range(3)], [x / n for x in q])


def mat(t: Transform) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_quat(np.asarray(t.rotation)).as_matrix()
    m[:3, 3] = t.translation
    return m


def ts(parent, child, stamp, tf) -> TransformStamped:
    return TransformStamped(parent, child, stamp, tf)


def assert_tf_close(a: Transform, b: Transform, atol=1e-9):
    assert a.almost_equal(b, atol=atol), f"{a} != {b}"


# ---------------------------------------------------------------- single edges
@pytest.mark.parametrize("static", [True, False])
def test_single_edge_returns_stored_values_exactly(static):
    b = Buffer()
    tf = Transform((1.5, -2.0, 3.25), (0.1, 0.2, 0.3, math.sqrt(1 - 0.14)))
    (b.set_transform_static if static else b.set_transform)(ts("world", "tower", 4.0, tf), "test")
    out = b.lookup_transform("world", "tower", 4.0)
    assert out.frame_id == "world" and out.child_frame_id == "tower" and out.stamp == 4.0
    assert out.transform == tf  # exact, not approximately
    # and it maps points in the child into the parent
    np.testing.assert_allclose(out.transform.apply_point([1, 0, 0]), mat(tf)[:3, :3] @ [1, 0, 0] + tf.translation)
    inv = b.lookup_transform("tower", "world", 4.0).transform
    assert_tf_close(inv, tf.inverse(), 1e-12)


def test_lookup_self_is_identity():
    b = Buffer()
    b.set_transform(ts("world", "drone", 2.0, Transform((1, 2, 3))))
    out = b.lookup_transform("drone", "drone")
    assert out.transform == Transform.identity() and out.stamp == 2.0  # tf2: the frame's latest
    assert b.lookup_transform("world", "world", 7.5).stamp == 7.5
    assert b.lookup_transform("world", "world").stamp == 0.0


# ---------------------------------------------------------------- random trees
@st.composite
def trees(draw):
    n = draw(st.integers(3, 6))
    seed = draw(st.integers(0, 2**32 - 1))
    parents = [None] + [draw(st.integers(0, i - 1)) for i in range(1, n)]
    static = [None] + [draw(st.booleans()) for _ in range(1, n)]
    return n, parents, static, seed


@given(trees(), st.data())
def test_chain_equals_product_of_edges(tree, data):
    n, parents, static, seed = tree
    rng = random.Random(seed)
    names = [f"f{i}" for i in range(n)]
    b = Buffer()
    edge = {}  # child index -> 4x4 (parent <- child), all samples equal so any time is exact
    for i in range(1, n):
        tf = rand_tf(rng)
        edge[i] = mat(tf)
        if static[i]:
            b.set_transform_static(ts(names[parents[i]], names[i], 0.0, tf))
        else:
            for stamp in (1.0, 2.0, 3.0):
                b.set_transform(ts(names[parents[i]], names[i], stamp, tf))

    def to_root(i):
        m = np.eye(4)
        while i:
            m = edge[i] @ m
            i = parents[i]
        return m

    a = data.draw(st.integers(0, n - 1))
    c = data.draw(st.integers(0, n - 1))
    t = data.draw(st.sampled_from([LATEST, 1.0, 2.5, 3.0]))
    out = b.lookup_transform(names[a], names[c], t)
    expect = np.linalg.inv(to_root(a)) @ to_root(c)
    np.testing.assert_allclose(out.transform.to_matrix(), expect, atol=1e-8)
    back = b.lookup_transform(names[c], names[a], t)
    np.testing.assert_allclose(back.transform.to_matrix(), np.linalg.inv(expect), atol=1e-8)
    assert_tf_close(out.transform * back.transform, Transform.identity(), 1e-9)
    # the frames on the path are the ones walked by hand
    path = b.chain(names[a], names[c])
    assert path[0] == names[c] and path[-1] == names[a]


# ---------------------------------------------------------------- interpolation
@st.composite
def quat(draw):
    v = np.array(draw(st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 4)))
    assume(np.linalg.norm(v) > 0.2)
    return v / np.linalg.norm(v)


@given(quat(), quat(), st.floats(0.0, 1.0), st.floats(-50, 50), st.floats(0.01, 5.0))
def test_interpolation_is_lerp_and_slerp(q0, q1, s, t0, dt):
    # exactly 180 deg apart the shortest path is not unique (scipy may turn the other way)
    assume(abs(np.dot(q0, q1)) > 1e-6)
    b = Buffer()
    p0, p1 = np.array([1.0, -2.0, 3.0]), np.array([4.0, 6.0, -9.0])
    b.set_transform(ts("world", "drone", t0, Transform(p0, q0)))
    b.set_transform(ts("world", "drone", t0 + dt, Transform(p1, q1)))
    t = t0 + s * dt
    assume(t0 <= t <= t0 + dt)
    out = b.lookup_transform("world", "drone", t).transform
    sl = Slerp([t0, t0 + dt], Rotation.from_quat([q0, q1]))   # shortest path by construction
    ref_q = sl([t]).as_quat()[0]
    frac = (t - t0) / dt
    np.testing.assert_allclose(out.translation, p0 + (p1 - p0) * frac, atol=1e-9)
    assert abs(abs(np.dot(out.rotation, ref_q)) - 1.0) < 1e-9
    ang = (Rotation.from_quat(out.rotation).inv() * Rotation.from_quat(ref_q)).magnitude()
    assert ang < 1e-6


def test_interpolation_exact_at_samples_and_handles_minus_q():
    b = Buffer()
    q = Rotation.from_euler("z", 170, degrees=True).as_quat()
    r = Rotation.from_euler("z", -170, degrees=True).as_quat()  # 20 deg away the short way
    b.set_transform(ts("world", "drone", 0.0, Transform((0, 0, 0), q)))
    b.set_transform(ts("world", "drone", 1.0, Transform((1, 0, 0), -r)))
    assert b.lookup_transform("world", "drone", 0.0).transform == Transform((0, 0, 0), q)
    assert b.lookup_transform("world", "drone", 1.0).transform == Transform((1, 0, 0), -r)
    mid = b.lookup_transform("world", "drone", 0.5).transform
    assert abs(abs(mid.yaw_pitch_roll()[0]) - math.pi) < 1e-12  # through 180, not through 0


def test_tiny_rotation_steps_still_match_slerp():
    b = Buffer()
    q0 = Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_quat()
    q1 = (Rotation.from_rotvec([1e-7, 0, 0]) * Rotation.from_quat(q0)).as_quat()
    b.set_transform(ts("w", "d", 0.0, Transform((0, 0, 0), q0)))
    b.set_transform(ts("w", "d", 1.0, Transform((0, 0, 0), q1)))
    out = b.lookup_transform("w", "d", 0.3).transform.rotation
    ref = Slerp([0, 1], Rotation.from_quat([q0, q1]))([0.3]).as_quat()[0]
    assert abs(abs(np.dot(out, ref)) - 1) < 1e-14


# ---------------------------------------------------------------- inserts and the window
def test_out_of_order_inserts_equal_in_order():
    rng = random.Random(3)
    samples = [(i * 0.1, rand_tf(rng)) for i in range(50)]
    a, b = Buffer(), Buffer()
    for t, tf in samples:
        a.set_transform(ts("w", "d", t, tf))
    shuffled = samples[:]
    rng.shuffle(shuffled)
    for t, tf in shuffled:
        b.set_transform(ts("w", "d", t, tf))
    for k in range(200):
        t = rng.uniform(0.0, 4.9)
        assert a.lookup_transform("w", "d", t).transform == b.lookup_transform("w", "d", t).transform


def test_duplicate_stamp_replaces():
    b = Buffer()
    b.set_transform(ts("w", "d", 1.0, Transform((1, 0, 0))))
    b.set_transform(ts("w", "d", 2.0, Transform((2, 0, 0))))
    b.set_transform(ts("w", "d", 1.0, Transform((5, 0, 0))))
    assert b.lookup_transform("w", "d", 1.0).transform == Transform((5, 0, 0))
    assert b.edge_stats()["d"].samples == 2


def test_window_expiry_and_old_data_rejected():
    b = Buffer(cache_time=10.0)
    for i in range(21):
        assert b.set_transform(ts("w", "d", float(i), Transform((i, 0, 0)))) is True
    s = b.edge_stats()["d"]
    assert (s.oldest, s.most_recent, s.samples) == (10.0, 20.0, 11)
    assert s.buffer_length == 10.0 and s.rate_hz == pytest.approx(1.0)
    with pytest.raises(PastExtrapolationException):
        b.lookup_transform("w", "d", 9.5)
    # older than newest - cache_time: refused and counted, nothing stored
    assert b.set_transform(ts("w", "d", 9.0, Transform((99, 0, 0)))) is False
    assert b.edge_stats()["d"].rejected_old == 1
    assert b.edge_stats()["d"].oldest == 10.0
    # exactly at the window edge and inside it, out of order: accepted
    assert b.set_transform(ts("w", "d", 10.5, Transform((10.5, 0, 0)))) is True
    assert b.lookup_transform("w", "d", 10.25).transform.translation[0] == pytest.approx(10.25)
    # a newer sample slides the window
    b.set_transform(ts("w", "d", 25.0, Transform((25, 0, 0))))
    assert b.edge_stats()["d"].oldest == 15.0


def test_zero_is_a_real_time_not_latest():
    b = Buffer()
    b.set_transform(ts("w", "d", 0.0, Transform((0, 0, 0))))
    b.set_transform(ts("w", "d", 1.0, Transform((1, 0, 0))))
    assert b.lookup_transform("w", "d", 0.0).transform.translation[0] == 0.0
    assert b.lookup_transform("w", "d", 0).stamp == 0.0
    latest = b.lookup_transform("w", "d", LATEST)
    assert latest.stamp == 1.0 and latest.transform.translation[0] == 1.0
    assert b.lookup_transform("w", "d").stamp == 1.0  # LATEST is the default


# ---------------------------------------------------------------- static and LATEST
def test_static_edges_answer_any_time_and_never_expire():
    b = Buffer(cache_time=1.0)
    tf = Transform((-133.6, 85.9, 0.0), Rotation.from_euler("z", 33, degrees=True).as_quat())
    b.set_transform_static(ts("world", "tower", 123.0, tf))
    for t in (-1e9, 0.0, 123.0, 1e12, LATEST):
        assert b.lookup_transform("world", "tower", t).transform == tf
    assert b.lookup_transform("world", "tower").stamp == 0.0  # all static: tf2's Time(0)
    b.set_transform_static(ts("tower", "mast", 0.0, Transform((0, 0, -10))))
    out = b.lookup_transform("mast", "world")  # an all-static chain answers LATEST
    assert out.stamp == 0.0
    np.testing.assert_allclose(out.transform.to_matrix(), np.linalg.inv(mat(tf) @ mat(Transform((0, 0, -10)))),
                               atol=1e-9)
    assert b.get_latest_common_time("mast", "world") == 0.0


def test_latest_is_min_of_newest_over_dynamic_edges():
    b = Buffer()
    b.set_transform_static(ts("world", "tower", 0.0, Transform((1, 0, 0))))
    for t in (1.0, 2.0, 3.0, 4.0):
        b.set_transform(ts("world", "drone", t, Transform((t, 0, 0))))
    for t in (0.5, 1.5, 2.5):
        b.set_transform(ts("drone", "drone_yaw", t, Transform((0, t, 0))))
    assert b.get_latest_common_time("tower", "drone_yaw") == 2.5
    out = b.lookup_transform("tower", "drone_yaw")
    assert out.stamp == 2.5
    np.testing.assert_allclose(out.transform.translation, [2.5 - 1.0, 2.5, 0.0])
    assert b.lookup_transform("tower", "drone").stamp == 4.0  # static edge does not constrain
    assert b.lookup_transform("drone", "drone_yaw").stamp == 2.5
    with pytest.raises(FutureExtrapolationException):
        b.lookup_transform("tower", "drone_yaw", 3.0)


def test_lookup_full_time_travel():
    b = Buffer()
    rng = random.Random(7)
    b.set_transform_static(ts("world", "tower", 0.0, rand_tf(rng)))
    d1, d2 = rand_tf(rng), rand_tf(rng)
    b.set_transform(ts("world", "drone", 1.0, d1))
    b.set_transform(ts("world", "drone", 2.0, d2))
    out = b.lookup_transform_full("drone", 2.0, "drone", 1.0, "world")
    assert out.frame_id == "drone" and out.child_frame_id == "drone" and out.stamp == 2.0
    np.testing.assert_allclose(out.transform.to_matrix(), np.linalg.inv(mat(d2)) @ mat(d1), atol=1e-9)
    # equals T(drone@t2 <- world) * T(world <- drone@t1) from plain lookups
    expect = b.lookup_transform("drone", "world", 2.0).transform * b.lookup_transform("world", "drone", 1.0).transform
    assert_tf_close(out.transform, expect, 1e-12)
    # through a static frame, with LATEST on the target side
    out = b.lookup_transform_full("tower", LATEST, "drone", 1.0, "world")
    assert out.stamp == 0.0
    assert b.can_transform_full("drone", 2.0, "drone", 1.0, "world")
    assert not b.can_transform_full("drone", 3.0, "drone", 1.0, "world")


# ---------------------------------------------------------------- stamped helpers
def test_transform_point_vector_pose():
    b = Buffer()
    tf1 = Transform((10, 0, 0), Rotation.from_euler("z", 90, degrees=True).as_quat())
    tf2 = Transform((20, 0, 0), Rotation.from_euler("z", 90, degrees=True).as_quat())
    b.set_transform(ts("world", "drone", 1.0, tf1))
    b.set_transform(ts("world", "drone", 3.0, tf2))
    p = b.transform_point(PointStamped("drone", 2.0, [1.0, 0.0, 0.0]), "world")
    assert p.frame_id == "world" and p.stamp == 2.0
    np.testing.assert_allclose(p.point, [15, 1, 0], atol=1e-12)  # uses the input's stamp
    pts = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    pb = b.transform_point(PointStamped("drone", 1.0, pts), "world")
    np.testing.assert_allclose(pb.point, [[10, 1, 0], [9, 0, 0]], atol=1e-12)
    v = b.transform_vector(VectorStamped("drone", 1.0, [1.0, 0.0, 0.0]), "world")
    np.testing.assert_allclose(v.vector, [0, 1, 0], atol=1e-12)
    pose = PoseStamped("drone", 1.0, [1.0, 0.0, 0.0], Rotation.from_euler("z", 90, degrees=True).as_quat())
    out = b.transform_pose(pose, "world")
    np.testing.assert_allclose(out.position, [10, 1, 0], atol=1e-12)
    assert abs(abs(np.dot(out.orientation, Rotation.from_euler("z", 180, degrees=True).as_quat())) - 1) < 1e-12
    latest = b.transform_point(PointStamped("drone", LATEST, [0, 0, 0]), "world")
    assert latest.stamp == 3.0
    with pytest.raises(ValueError):
        p.point[0] = 1.0  # results are read-only like the inputs


# ---------------------------------------------------------------- structure changes
def test_reparent_moves_child():
    b = Buffer()
    b.set_transform_static(ts("world", "a", 0.0, Transform((1, 0, 0))))
    b.set_transform_static(ts("world", "b", 0.0, Transform((0, 1, 0))))
    b.set_transform(ts("a", "drone", 1.0, Transform((0, 0, 1))))
    np.testing.assert_allclose(b.lookup_transform("world", "drone").transform.translation, [1, 0, 1])
    v = b.structure_version
    b.set_transform(ts("b", "drone", 2.0, Transform((0, 0, 1))))
    assert b.structure_version > v
    np.testing.assert_allclose(b.lookup_transform("world", "drone").transform.translation, [0, 1, 1])
    assert "Frame drone exists with parent b." in b.all_frames_as_string()
    assert b.edge_stats()["drone"].samples == 1  # history under the old parent dropped


def test_static_dynamic_switch_replaces_edge():
    b = Buffer()
    b.set_transform(ts("w", "d", 1.0, Transform((1, 0, 0))))
    b.set_transform_static(ts("w", "d", 0.0, Transform((2, 0, 0))))
    assert b.edge_stats()["d"].is_static
    assert b.lookup_transform("w", "d", 55.0).transform.translation[0] == 2.0
    b.set_transform(ts("w", "d", 5.0, Transform((3, 0, 0))))
    assert not b.edge_stats()["d"].is_static


def test_introspection_and_clear():
    import yaml  # PyYAML is a declared test dependency
    b = Buffer()
    b.set_transform_static(ts("world", "tower", 0.0, Transform((1, 0, 0))), authority="scenario")
    for i in range(11):
        b.set_transform(ts("world", "drone", 1.0 + i * 0.1, Transform((i, 0, 0))), authority="bridge")
    assert b.frames() == ["drone", "tower", "world"]
    s = b.all_frames_as_string()
    assert s == "Frame tower exists with parent world.\nFrame drone exists with parent world.\n"
    y = yaml.safe_load(b.all_frames_as_yaml())
    assert y["tower"] == {"parent": "world", "broadcaster": "scenario", "rate": 10000.0,
                          "most_recent_transform": 0.0, "oldest_transform": 0.0, "buffer_length": 0.0}
    assert y["drone"]["parent"] == "world" and y["drone"]["broadcaster"] == "bridge"
    assert y["drone"]["rate"] == pytest.approx(10.0, abs=1e-3)
    assert y["drone"]["most_recent_transform"] == 2.0 and y["drone"]["oldest_transform"] == 1.0
    assert y["drone"]["buffer_length"] == 1.0
    assert "transform_delay: 1.000" in b.all_frames_as_yaml(current_time=3.0)
    st_ = b.edge_stats()
    assert st_["drone"].authority == "bridge" and st_["drone"].parent == "world"
    assert st_["drone"].rate_hz == pytest.approx(10.0) and not st_["drone"].is_static
    assert st_["tower"].is_static and st_["tower"].authority == "scenario"
    b.clear()
    assert b.frames() == ["drone", "tower", "world"]   # tf2 keeps knowing them (tests/test_frames_tf2_rules.py)
    assert b.lookup_transform("world", "tower").transform == Transform((1, 0, 0))
    assert not b.can_transform("world", "drone")
    assert Buffer().all_frames_as_yaml() == "[]"


@given(trees(), st.data())
def test_interpolated_chain_is_product_of_interpolated_edges(tree, data):
    """Samples differ per stamp; at an interpolated time the chain equals the product of
    the single-edge lookups, and the generated evaluator equals the reference loop."""
    n, parents, static, seed = tree
    rng = random.Random(seed)
    names = [f"f{i}" for i in range(n)]
    fast, ref = Buffer(), Buffer()
    for i in range(1, n):
        p, c = names[parents[i]], names[i]
        if static[i]:
            tf = rand_tf(rng)
            for b in (fast, ref):
                b.set_transform_static(ts(p, c, 0.0, tf))
        else:
            for stamp in (1.0, 1.5, 2.0, 3.0):
                tf = rand_tf(rng)
                if stamp not in (1.0, 3.0):
                    stamp += rng.uniform(-0.2, 0.2)
                for b in (fast, ref):
                    b.set_transform(ts(p, c, stamp, tf))
    a = data.draw(st.integers(0, n - 1))
    c = data.draw(st.integers(0, n - 1))
    t = data.draw(st.floats(1.0, 3.0))

    def to_root(i):
        m = np.eye(4)
        while i:
            m = fast.lookup_transform(names[parents[i]], names[i], t).transform.to_matrix() @ m
            i = parents[i]
        return m

    out = fast.lookup_transform(names[a], names[c], t)
    np.testing.assert_allclose(out.transform.to_matrix(), np.linalg.inv(to_root(a)) @ to_root(c), atol=1e-8)
    slow = reference_lookup(ref, names[a], names[c], t)
    assert out.stamp == slow.stamp
    assert_tf_close(out.transform, slow.transform, 1e-12)
    for time_ in (LATEST, 0.5, 3.5):
        try:
            r1 = fast.lookup_transform(names[a], names[c], time_)
        except Exception as e1:
            with pytest.raises(type(e1)):
                reference_lookup(ref, names[a], names[c], time_)
        else:
            r2 = reference_lookup(ref, names[a], names[c], time_)
            assert r1.stamp == r2.stamp
            assert_tf_close(r1.transform, r2.transform, 1e-12)


@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 2**31 - 1)), min_size=2, max_size=60),
       st.lists(st.floats(0.0, 4.0), min_size=1, max_size=20))
def test_out_of_order_and_duplicate_inserts_match_reference(inserts, times):
    """Per-segment SLERP constants are kept right through out-of-order inserts,
    duplicates (replacing) and pruning: the fast path equals the reference loop."""
    fast, ref = Buffer(cache_time=3.0), Buffer(cache_time=3.0)
    for k, seed in inserts:
        tf = rand_tf(random.Random(seed))
        accepted = [b.set_transform(ts("w", "d", k * 0.1, tf)) for b in (fast, ref)]
        assert accepted[0] == accepted[1]
    assert fast.edge_stats() == ref.edge_stats()
    for t in times:
        try:
            r1 = fast.lookup_transform("w", "d", t).transform
        except Exception as e1:
            with pytest.raises(type(e1)):
                reference_lookup(ref, "w", "d", t)
        else:
            r2 = reference_lookup(ref, "w", "d", t).transform
            assert r1 == r2  # same arithmetic, bit for bit
