"""common.tf2_ros: the MessageFilter's queue (pure), and broadcaster -> listener over real sockets."""
from __future__ import annotations

import numpy as np
import pytest

from common.frames import LATEST, Buffer, PointStamped, Transform, TransformStamped
from common.tf2_ros import (FilterFailureReason as R, FilterQueue, MessageFilter, Node,
                         StaticTransformBroadcaster, TransformBroadcaster, TransformListener)
from tests.support import free_port, wait_until


def ts(parent, child, t, x=0.0, yaw=0.0):
    return TransformStamped(parent, child, float(t), Transform.from_euler(yaw=yaw, translation=(x, 0, 0)))


# ----------------------------------------------------------------------------- FilterQueue (pure)


def test_filter_holds_a_point_until_its_transform_exists_then_delivers_it():
    buf = Buffer()
    q = FilterQueue(buf, "world", queue_size=5, timeout=None)
    p = PointStamped("camera", 2.0, (1, 0, 0))
    r = q.add(p, now=0.0)
    assert r.ready == [] and r.dropped == [] and len(q) == 1
    buf.set_transform_static(ts("drone", "camera", 0, x=0.5), "cam")
    assert q.poll(1.0).ready == []                       # drone not yet in world
    buf.set_transform(ts("world", "drone", 1.0, x=10), "w2d")
    assert q.poll(1.1).ready == []                       # data only up to 1.0: 2.0 is the future
    buf.set_transform(ts("world", "drone", 3.0, x=12), "w2d")
    r = q.poll(1.2)
    assert r.ready == [p] and len(q) == 0
    out = buf.transform_point(p, "world")
    assert np.allclose(out.point, (11 + 0.5 + 1, 0, 0))   # drone at 11 at t=2 (interpolated)


def test_filter_delivers_at_once_when_transformable_and_keeps_arrival_order():
    buf = Buffer()
    buf.set_transform_static(ts("world", "tower", 0, x=1), "sc")
    q = FilterQueue(buf, "world")
    a = PointStamped("drone", 1.0, (0, 0, 0))
    b = PointStamped("drone", 2.0, (0, 0, 0))
    c = PointStamped("tower", LATEST, (0, 0, 0))
    q.add(a, 0.0)
    q.add(b, 0.0)
    assert q.add(c, 0.0).ready == [c]
    buf.set_transform(ts("world", "drone", 0.5), "w")
    buf.set_transform(ts("world", "drone", 2.5), "w")
    assert q.poll(0.1).ready == [a, b]


def test_filter_drops_what_waits_longer_than_the_timeout_with_its_reason():
    buf = Buffer()
    q = FilterQueue(buf, "world", timeout=0.5)
    p = PointStamped("camera", 1.0, (0, 0, 0))
    q.add(p, now=10.0)
    assert q.poll(10.5).dropped == []                    # exactly the timeout: still waiting
    r = q.poll(10.51)
    assert [(m, why) for m, why, _ in r.dropped] == [(p, R.NoTransformFound)]
    assert "camera" in r.dropped[0][2] and "waited 0.51 s" in r.dropped[0][2]
    assert len(q) == 0


def test_filter_queue_full_pushes_out_the_oldest():
    q = FilterQueue(Buffer(), "world", queue_size=2)
    ps = [PointStamped("camera", float(i), (0, 0, 0)) for i in range(3)]
    assert q.add(ps[0], 0).dropped == [] and q.add(ps[1], 0).dropped == []
    r = q.add(ps[2], 0)
    assert [(m, why) for m, why, _ in r.dropped] == [(ps[0], R.QueueFull)]
    assert [w.msg for w in q.queue] == ps[1:]


def test_filter_drops_out_the_back_and_empty_frame_ids():
    buf = Buffer(cache_time=10.0)
    for t in (0.0, 30.0):
        buf.set_transform(ts("world", "drone", t), "w")
    q = FilterQueue(buf, "world")
    old = PointStamped("drone", 5.0, (0, 0, 0))          # 25 s behind the newest, cache 10 s
    r = q.add(old, 0)
    assert [(m, why) for m, why, _ in r.dropped] == [(old, R.OutTheBack)]
    r = q.add(PointStamped("", 1.0, (0, 0, 0)), 0)
    assert [why for _, why, _ in r.dropped] == [R.EmptyFrameID]
    with pytest.raises(ValueError):
        FilterQueue(buf, "world", queue_size=-1)


def test_message_filter_over_a_buffer_counts_and_reports_drops():
    buf = Buffer()
    now = [0.0]
    mf = MessageFilter(buf, "world", queue_size=1, timeout=1.0, clock=lambda: now[0])
    got, failed = [], []
    mf.register_callback(got.append)
    mf.register_failure_callback(lambda m, why: failed.append((m, why)))
    a, b = PointStamped("cam", 1.0, (0, 0, 0)), PointStamped("cam", 2.0, (0, 0, 0))
    mf.add(a)
    mf.add(b)                                            # queue_size 1: a goes
    assert failed == [(a, R.QueueFull)] and mf.waiting == 1
    now[0] = 2.0
    mf.poll()
    assert failed[-1] == (b, R.NoTransformFound) and got == []
    assert mf.dropped[R.QueueFull] == 1 and mf.dropped[R.NoTransformFound] == 1
    with pytest.raises(TypeError, match="TransformListener or a Buffer"):
        MessageFilter("world", "world")


# ----------------------------------------------------------------------------- over sockets


@pytest.fixture
def node_pair():
    """A node that listens (udpin) and a node that sends to it (udpout), as two programs would."""
    port = free_port()
    rx = Node("rx", f"udpin:127.0.0.1:{port}")
    tx = Node("tx", f"udpout:127.0.0.1:{port}")
    try:
        yield tx, rx
    finally:
        tx.close()
        rx.close()


def test_broadcast_frame_is_looked_up_by_another_nodes_listener(node_pair):
    tx, rx = node_pair
    buf = Buffer()
    listener = TransformListener(buf, rx)
    br = TransformBroadcaster(tx)
    br.send_transform([ts("world", "drone", 1.0, x=3.0), ts("world", "drone", 2.0, x=5.0)])
    wait_until(lambda: buf.can_transform("world", "drone", 2.0), 5.0, "world->drone at 2.0")
    got = buf.lookup_transform("world", "drone", 1.5)
    assert np.allclose(got.transform.translation, (4.0, 0, 0))
    assert buf.edge_stats()["drone"].authority == f"mavlink:{tx.source_system}"
    assert listener.received == 2
    with pytest.raises(ValueError, match="longer than 16 bytes"):
        br.send_transform(ts("world", "a_frame_name_too_long", 1.0))
    with pytest.raises(TypeError):
        br.send_transform("world drone")


def test_static_broadcaster_is_latched_for_a_late_listener(node_pair):
    tx, rx = node_pair
    sb = StaticTransformBroadcaster(tx, period=0.1)
    sb.send_transform(ts("drone", "camera", 0.0, x=0.2))   # sent before anyone listens
    buf = Buffer()
    TransformListener(buf, rx)                             # joins late
    wait_until(lambda: buf.can_transform("drone", "camera", 123.0), 5.0, "latched static")
    assert buf.edge_stats()["camera"].is_static


def test_message_filter_on_a_listener_delivers_when_the_frame_arrives(node_pair):
    tx, rx = node_pair
    buf = Buffer()
    listener = TransformListener(buf, rx)
    mf = MessageFilter(listener, "world", queue_size=10, timeout=5.0)
    got = []
    mf.register_callback(lambda p: got.append(mf.transform(p)))
    mf.add(PointStamped("drone", 1.0, (1, 0, 0)))
    assert got == [] and mf.waiting == 1
    TransformBroadcaster(tx).send_transform([ts("world", "drone", 0.5, x=10), ts("world", "drone", 1.5, x=10)])
    wait_until(lambda: got, 5.0, "the filter's delivery")
    assert np.allclose(got[0].point, (11, 0, 0)) and got[0].frame_id == "world"
    mf.close()


# ----------------------------------------------------------------------------- FilterQueue: properties

from hypothesis import given, settings, strategies as st  # noqa: E402

# one step: ("add", frame, stamp) | ("tf", stamp) a world->drone sample | ("wait", seconds)
_steps = st.lists(st.one_of(
    st.tuples(st.just("add"), st.sampled_from(["drone", "camera", "nowhere"]), st.floats(0, 20)),
    st.tuples(st.just("tf"), st.floats(0, 20)),
    st.tuples(st.just("wait"), st.floats(0, 1))), max_size=40)


@settings(max_examples=150, deadline=None)
@given(_steps, st.integers(0, 4), st.one_of(st.none(), st.floats(0.1, 2)))
def test_filter_accounts_for_every_message_once_and_in_order(steps, queue_size, timeout):
    buf = Buffer(cache_time=5.0)
    buf.set_transform_static(ts("drone", "camera", 0.0, x=0.1), "cam")
    q = FilterQueue(buf, "world", queue_size=queue_size, timeout=timeout)
    now, added, fates = 0.0, [], {}
    for step in steps:
        if step[0] == "add":
            m = PointStamped(step[1], step[2], (0, 0, 0))
            added.append(m)
            r = q.add(m, now)
        elif step[0] == "tf":
            buf.set_transform(ts("world", "drone", step[1]), "w")
            r = q.poll(now)
        else:
            now += step[1]
            r = q.poll(now)
        for m in r.ready:
            assert id(m) not in fates
            assert buf.can_transform("world", m.frame_id, m.stamp)     # delivered only when transformable
            fates[id(m)] = "ready"
        for m, why, _detail in r.dropped:
            assert id(m) not in fates
            if why is R.QueueFull:
                assert queue_size > 0
            if why is R.NoTransformFound:
                assert timeout is not None
            fates[id(m)] = why
        assert queue_size == 0 or len(q) <= queue_size
    waiting = {id(w.msg) for w in q.queue}
    assert all((id(m) in fates) != (id(m) in waiting) for m in added)   # each one: decided xor waiting
    assert [w.msg for w in q.queue] == [m for m in added if id(m) in waiting]   # arrival order kept
    assert not any(m.frame_id == "nowhere" and fates.get(id(m)) == "ready" for m in added)
