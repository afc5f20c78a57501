"""Dynamic frames from telemetry: pairing by time_boot_ms, reordered / duplicate / lost
packets, vehicle reboot; the transform stream as the tower sees it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import LATEST, Buffer, Transform
from common.tf2_ros.wire import transform_message
from bridge.listener import TransformListener
from bridge.pairing import VehicleFrames
from bridge.timeline import Timeline
from bridge_fakes import bridge_with_fakes
from support import wait_until


def q_wxyz(T):
    x, y, z, w = T.xyzw
    return (w, x, y, z)


def test_pairing_exact_and_interpolated():
    vf = VehicleFrames("drone")
    assert vf.on_local_position(100, 1, 2, -3, 0, 0, 0) == []          # waits for attitude
    T = Transform.from_euler(yaw=0.5, pitch=0.1, roll=-0.2)
    out = vf.on_attitude_quaternion(100, *q_wxyz(T))
    assert len(out) == 1 and out[0].stamp == 0.1
    assert out[0].full.transform.almost_equal(Transform(translation=(1, 2, -3), rotation=T.xyzw), 1e-9)
    assert out[0].yaw.child_frame_id == "drone_yaw"
    # drone_yaw, by hand: the same origin, turned by the yaw of 0.5 rad about z only
    yaw_tf = out[0].yaw.transform
    assert yaw_tf.xyz == pytest.approx((1, 2, -3), abs=1e-12)
    assert tuple(yaw_tf.apply_vector((1, 0, 0))) == pytest.approx((math.cos(0.5), math.sin(0.5), 0), abs=1e-9)
    assert tuple(yaw_tf.apply_vector((0, 0, 1))) == pytest.approx((0, 0, 1), abs=1e-9)
    assert abs(np.dot(yaw_tf.xyzw, (0, 0, math.sin(0.25), math.cos(0.25)))) == pytest.approx(1, abs=1e-12)
    # a position between two attitudes (streams at different phases): SLERP
    vf.on_attitude_quaternion(200, *q_wxyz(Transform.from_euler(yaw=0.0)))
    assert vf.on_local_position(250, 0, 0, 0, 0, 0, 0) == []
    out = vf.on_attitude_quaternion(300, *q_wxyz(Transform.from_euler(yaw=1.0)))
    assert len(out) == 1 and out[0].stamp == 0.25
    assert out[0].full.transform.yaw_pitch_roll()[0] == pytest.approx(0.5, abs=1e-9)


def test_duplicates_ignored_reorder_kept_reboot_resets():
    vf = VehicleFrames("rover")
    samples = []
    for ms in (100, 300, 200):                       # 200 arrives late
        samples += vf.on_local_position(ms, ms / 100, 0, 0, 0, 0, 0)
        samples += vf.on_attitude_quaternion(ms, 1, 0, 0, 0)
    assert [s.stamp for s in samples] == [0.1, 0.3, 0.2] and vf.reordered >= 1
    assert vf.on_local_position(300, 9, 9, 9, 0, 0, 0) == [] and vf.duplicates == 1
    assert vf.on_attitude_quaternion(300, 1, 0, 0, 0) == []
    buf = Buffer()
    for s in samples:
        buf.set_transform(s.full)
    assert buf.lookup_transform("world", "rover", 0.25).transform.xyz == pytest.approx((2.5, 0, 0))
    # reboot: the clock restarts near zero; the timeline (the one owner of the vehicle's
    # clock) says so, and pairing starts over on its word
    line = Timeline()
    assert not line.clock("rover", 50.0, wall=0.0)
    vf.on_local_position(50_000, 0, 0, 0, 0, 0, 0); vf.on_attitude_quaternion(50_000, 1, 0, 0, 0)
    assert line.clock("rover", 0.02, wall=0.1)
    vf.reset()
    out = vf.on_local_position(20, 7, 0, 0, 0, 0, 0) + vf.on_attitude_quaternion(20, 1, 0, 0, 0)
    assert len(out) == 1 and line.frame_stamp("rover", out[0].stamp) and vf.resets == 1
    assert out[0].full.transform.xyz == pytest.approx((7, 0, 0))


@pytest.fixture
def world():
    with bridge_with_fakes(rover=False, heartbeats=False) as w:
        yield w["bridge"], w["tower"], w["drone"]


def test_bridge_buffer_reorder_duplicate_loss_reboot(world):
    bridge, tower, drone = world
    order = [1000, 1100, 1300, 1200, 1200, 1500]      # 1200 late and duplicated, 1400 lost
    for ms in order:
        drone.pose(ms, (ms / 1000.0, 0, -5))
    wait_until(lambda: bridge.buffer.edge_stats().get("drone") and
               bridge.buffer.edge_stats()["drone"].samples == 5, 5, "5 samples stored")
    st = bridge.buffer.edge_stats()["drone"]
    assert st.most_recent == 1.5 and st.oldest == 1.0
    # world -> drone goes through drone_origin, known once the drone answers GPS_GLOBAL_ORIGIN
    wait_until(lambda: bridge.origins.known("drone"), 5, "drone origin")
    # stamped with the drone clock: lookups at its stamps are exact, between them interpolated
    assert bridge.buffer.lookup_transform("world", "drone", 1.2).transform.xyz[0] == pytest.approx(1.2)
    assert bridge.buffer.lookup_transform("world", "drone", 1.45).transform.xyz[0] == pytest.approx(1.45)
    # attitude only for a stamp: no transform for it (no guess)
    drone.pose(1600, (9, 9, 9), pos=False)
    drone.pose(1700, (1.7, 0, -5))
    wait_until(lambda: bridge.buffer.edge_stats()["drone"].most_recent == 1.7, 5, "1.7 stored")
    # reboot: clock restarts at 0.1 s; the old history is dropped, not mixed in
    drone.pose(100, (42, 0, -5))
    wait_until(lambda: bridge.buffer.edge_stats()["drone"].most_recent == 0.1, 5, "reset edge")
    st = bridge.buffer.edge_stats()["drone"]
    assert st.samples == 1
    assert bridge.buffer.lookup_transform("world", "drone", LATEST).transform.xyz[0] == 42
    assert any("reboot" in line for line in bridge.logs)


def test_transform_stream_reaches_tower(world):
    bridge, tower, drone = world
    T = Transform.from_euler(yaw=0.7, pitch=0.2, roll=0.1, translation=(3, 4, -9))
    drone.pose(2000, T.xyz, q_wxyz(T))
    m = tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "drone")
    # the drone's pose is in its own local frame, centred on its EKF origin (GPS_GLOBAL_ORIGIN)
    assert m.time_usec == 2_000_000 and m.frame_id == "drone_origin" and not m.flags & 1
    o = tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "drone_origin")
    assert o.frame_id == "world" and o.flags & 1
    np.testing.assert_allclose(m.translation, T.xyz, atol=1e-5)
    np.testing.assert_allclose(np.abs(np.dot(m.rotation, T.xyzw)), 1.0, atol=1e-6)
    tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "drone_yaw")
    tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "tower" and m.flags & 1)
    # a listener rebuilds the same tree
    lis = TransformListener()
    for msg in tower.of_type("TOWERLINK_TRANSFORM"):
        lis.feed(msg)
    got = lis.buffer.lookup_transform("tower", "drone_yaw", LATEST)
    want = bridge.buffer.lookup_transform("tower", "drone_yaw", LATEST)
    assert got.transform.almost_equal(want.transform, 1e-5) and got.stamp == 2.0


def test_transform_message_roundtrip():
    from common.frames import TransformStamped
    from common.tf2_ros.wire import transform_from_message
    ts = TransformStamped("world", "a_long_frame_16c", 12.345678,
                          Transform.from_euler(yaw=1, pitch=0.2, roll=0.3, translation=(1, 2, 3)))
    msg = transform_message(ts, static=True)
    dec = tl.MAVLink(None).decode(bytearray(msg.pack(tl.MAVLink(None, 250, 191))))
    back, static = transform_from_message(dec)
    assert static and back.child_frame_id == "a_long_frame_16c" and back.stamp == pytest.approx(12.345678)
    assert back.transform.almost_equal(ts.transform, 1e-6)
    with pytest.raises(ValueError):
        transform_message(TransformStamped("world", "x" * 17, 0.0, Transform.identity()))
