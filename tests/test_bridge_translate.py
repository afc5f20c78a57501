"""Frame translation through a running bridge, checked against common.frames math.

tower -> drone: SET_POSITION_TARGET_LOCAL_NED (point, vectors, yaw); drone -> tower:
LOCAL_POSITION_NED and POSITION_TARGET_LOCAL_NED; goals in named frames
(TOWERLINK_POSITION_TARGET) wait for their transform and are never sent with a stale
one; statics added live with TOWERLINK_STATIC_TRANSFORM.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import Transform
from common.scenario import load_scenario
from bridge_fakes import bridge_with_fakes, sync
from support import wait_until

SC = load_scenario()
T_WT = SC.buffer().lookup_transform("world", "tower").transform   # tower -> world
T_TW = T_WT.inverse()
YAW_WT = T_WT.yaw_pitch_roll()[0]


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


@pytest.fixture
def world():
    with bridge_with_fakes(out=True) as w:
        yield w["bridge"], w["tower"], w["drone"], w["rover"], w["out"]


def test_tower_goal_to_world(world):
    bridge, tower, drone, rover, out = world
    p_t = (-131.039, 73.524, -9.0)          # the lab's house, world [-4, -2]
    v_t = (1.0, 2.0, -0.5)
    yaw_t = 0.3
    tower.mav.set_position_target_local_ned_send(4242, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b0000_1100_0000,
                                                 *p_t, *v_t, 0, 0, 0, yaw_t, 0.1)
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED")
    assert (m.get_srcSystem(), m.get_srcComponent()) == (255, 190)
    assert m.time_boot_ms == 4242 and m.coordinate_frame == tl.MAV_FRAME_LOCAL_NED
    np.testing.assert_allclose((m.x, m.y, m.z), T_WT.apply_point(p_t), atol=1e-3)
    np.testing.assert_allclose((m.x, m.y), (-4.0, -2.0), atol=0.06)
    np.testing.assert_allclose((m.vx, m.vy, m.vz), T_WT.apply_vector(v_t), atol=1e-4)
    assert abs(wrap(m.yaw - (yaw_t + YAW_WT))) < 1e-5
    assert m.yaw_rate == pytest.approx(0.1)
    # LOCAL_OFFSET_NED: the offset is a vector
    tower.mav.set_position_target_local_ned_send(1, 1, 1, tl.MAV_FRAME_LOCAL_OFFSET_NED, 0b1111_1111_1000,
                                                 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED", lambda m: m.coordinate_frame == tl.MAV_FRAME_LOCAL_OFFSET_NED)
    np.testing.assert_allclose((m.x, m.y, m.z), T_WT.apply_vector((10, 0, 0)), atol=1e-4)
    # body frames are frame-independent: forwarded unchanged
    tower.mav.set_position_target_local_ned_send(2, 1, 1, tl.MAV_FRAME_BODY_OFFSET_NED, 0b1111_1111_1000,
                                                 3, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED", lambda m: m.coordinate_frame == tl.MAV_FRAME_BODY_OFFSET_NED)
    assert (m.x, m.y) == (3, 4)
    sync(tower, rover)                  # whatever the bridge sent the rover so far has arrived
    assert not rover.of_type("SET_POSITION_TARGET_LOCAL_NED")


def test_telemetry_to_tower_frame(world):
    bridge, tower, drone, rover, out = world
    p_w, v_w = (-4.0, -2.0, -9.0), (1.5, -0.5, 0.2)
    drone.mav.local_position_ned_send(777, *p_w, *v_w)
    m = tower.wait("LOCAL_POSITION_NED", lambda m: m.get_srcSystem() == 1)
    assert m.time_boot_ms == 777 and m.get_srcComponent() == 1
    np.testing.assert_allclose((m.x, m.y, m.z), T_TW.apply_point(p_w), atol=1e-3)
    np.testing.assert_allclose((m.x, m.y), (-131.039, 73.524), atol=0.06)
    np.testing.assert_allclose((m.vx, m.vy, m.vz), T_TW.apply_vector(v_w), atol=1e-4)
    # the world-frame out gets the raw message
    r = out.wait("LOCAL_POSITION_NED")
    assert (r.x, r.y, r.z) == pytest.approx(p_w)
    drone.mav.position_target_local_ned_send(778, tl.MAV_FRAME_LOCAL_NED, 0b1001_1100_0000,
                                             *p_w, *v_w, 0, 0, 0, 1.0, 0.2)
    m = tower.wait("POSITION_TARGET_LOCAL_NED")
    np.testing.assert_allclose((m.x, m.y, m.z), T_TW.apply_point(p_w), atol=1e-3)
    np.testing.assert_allclose((m.vx, m.vy, m.vz), T_TW.apply_vector(v_w), atol=1e-4)
    assert abs(wrap(m.yaw - (1.0 - YAW_WT))) < 1e-5 and m.time_boot_ms == 778


def test_named_frame_goal_waits_for_transform_then_goes(world):
    bridge, tower, drone, rover, out = world
    # goal 5 m ahead of the yaw-only drone frame, before any drone telemetry
    tower.mav.towerlink_position_target_send(1, 1, 1, b"drone_yaw", 0b1111_1111_1000 & ~0b111,
                                             5, 0, 0, 0, 0, 0, 0, 0)
    st = tower.wait("STATUSTEXT", lambda m: "goal waits" in m.text)
    assert st.get_srcSystem() == 250
    wait_until(lambda: bridge.tower.stats.deferred >= 3, 5, "goal retried on ticks")
    sync(tower, drone)
    assert not drone.of_type("SET_POSITION_TARGET_LOCAL_NED")
    # telemetry arrives: yawed 90 deg, pitched 10 deg, at (1, 2, -9)
    T = Transform.from_euler(yaw=math.pi / 2, pitch=math.radians(10), roll=0, translation=(1, 2, -9))
    x, y, z, w = T.xyzw
    drone.pose(1000, (1, 2, -9), (w, x, y, z))
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED")
    # 5 m along the drone's heading (north + 90 deg = east), level whatever its pitch
    np.testing.assert_allclose((m.x, m.y, m.z), (1, 2 + 5, -9), atol=1e-4)
    assert m.coordinate_frame == tl.MAV_FRAME_LOCAL_NED and (m.get_srcSystem(), m.get_srcComponent()) == (255, 190)
    # the bridge's thread sends the goal, then takes it off its list
    wait_until(lambda: 1 not in bridge.goals.pending, 5, "the sent goal off the pending list")


def test_stale_dynamic_transform_never_used(world):
    bridge, tower, drone, rover, out = world
    drone.pose(1000, (0, 0, -5))
    wait_until(lambda: bridge.buffer.can_transform("world", "drone"), 5, "drone frame")
    # the world clock moves on (rover telemetry at t = 3 s) but the drone is silent
    rover.pose(3000, (0, 0, 0))
    wait_until(lambda: bridge.timeline.world_clock() == 3.0, 5, "rover clock")
    tower.mav.towerlink_position_target_send(1, 1, 1, b"drone", 0b1111_1111_1000, 1, 0, 0, 0, 0, 0, 0, 0)
    tower.wait("STATUSTEXT", lambda m: "goal waits" in m.text)
    wait_until(lambda: bridge.tower.stats.deferred >= 3, 5, "retried")
    sync(tower, drone)
    assert not drone.of_type("SET_POSITION_TARGET_LOCAL_NED"), "a stale transform was used"
    # fresh telemetry: the goal is sent with the fresh pose, not the old one
    drone.pose(3000, (10, 0, -5))
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED")
    assert (m.x, m.y, m.z) == pytest.approx((11, 0, -5), abs=1e-4)


def test_static_transform_added_live(world):
    bridge, tower, drone, rover, out = world
    q = Transform.from_euler(yaw=math.pi).xyzw
    tower.mav.towerlink_static_transform_send(0, 0, b"world", b"pad", [10, 20, 0], list(q))
    tower.wait("STATUSTEXT", lambda m: "pad" in m.text)
    st = tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "pad")
    assert st.flags & 1 and list(st.translation) == [10, 20, 0]
    tower.mav.towerlink_position_target_send(1, 1, 1, b"pad", 0b1111_1111_1000, 1, 2, -3, 0, 0, 0, 0, 0)
    m = drone.wait("SET_POSITION_TARGET_LOCAL_NED")
    assert (m.x, m.y, m.z) == pytest.approx((9, 18, -3), abs=1e-4)
    # the bridge refuses to let a static replace a frame it owns
    tower.mav.towerlink_static_transform_send(0, 0, b"world", b"drone", [0, 0, 0], [0, 0, 0, 1])
    tower.wait("STATUSTEXT", lambda m: "refused" in m.text)
    # streamed again at ~1 Hz, with the scenario's tower
    out.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "tower")
