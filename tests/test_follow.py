"""Rover follow: the ground-point math (hypothesis) and the loop in a running bridge."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from common.mavlink.dialect import towerlink as tl
from bridge.follow import FollowSupervisor, ground_points
from common.frames import Transform
from bridge_fakes import Endpoint, FakeVehicle, bridge_config, running_bridge, sync, wait_origins
from support import free_ports, wait_until

angle = st.floats(-math.pi, math.pi, allow_nan=False)
tilt = st.floats(-0.6, 0.6, allow_nan=False)          # up to ~34 deg, ANGLE_MAX is 30
coord = st.floats(-500, 500, allow_nan=False)
height = st.floats(0.0, 100.0, allow_nan=False)
off = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(angle, tilt, tilt, coord, coord, height, off, off)
def test_yaw_only_ground_point_invariant_to_roll_pitch(yaw, pitch, roll, x, y, h, ox, oy):
    level = ground_points(Transform.from_euler(yaw=yaw, translation=(x, y, -h)), offset=(ox, oy))
    tilted = ground_points(Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll, translation=(x, y, -h)),
                           offset=(ox, oy))
    assert tilted.yaw == pytest.approx(level.yaw, abs=1e-6)
    assert tilted.err_yaw == pytest.approx(0.0, abs=1e-6)
    # the reference is the drone's position plus the yaw-rotated offset
    c, s = math.cos(yaw), math.sin(yaw)
    assert tilted.ref == pytest.approx((x + c * ox - s * oy, y + s * ox + c * oy), abs=1e-6)


@settings(max_examples=300, deadline=None)
@given(angle, tilt, coord, coord, height)
def test_full_attitude_swings_with_tilt(yaw, pitch, x, y, h):
    # The point (0, 0, h) of the tilted body frame, transformed to world, lies h*sin(tilt)
    # from the point below (h*tan(tilt) would be where the body z axis meets the ground;
    # the two agree to 2 % at 0.2 rad). Pure pitch swings it along the heading.
    gp = ground_points(Transform.from_euler(yaw=yaw, pitch=pitch, translation=(x, y, -h)))
    assert gp.err_full == pytest.approx(h * abs(math.sin(pitch)), abs=1e-6 + 1e-9 * h)
    dx, dy = gp.full[0] - gp.ref[0], gp.full[1] - gp.ref[1]
    along = dx * math.cos(yaw) + dy * math.sin(yaw)
    assert along == pytest.approx(h * math.sin(pitch), abs=1e-6)   # nose up: body z points ahead
    assert gp.tilt == pytest.approx(abs(pitch), abs=1e-6)
    assert gp.height == pytest.approx(h)


@settings(max_examples=200, deadline=None)
@given(angle, tilt, tilt, height)
def test_full_attitude_error_matches_geometry(yaw, pitch, roll, h):
    T = Transform.from_euler(yaw=yaw, pitch=pitch, roll=roll, translation=(0, 0, -h))
    gp = ground_points(T)
    # direct geometry: body z axis through the drone, rotated; offset = h * (R e_z)_xy
    p = T.rotation_matrix() @ np.array((0, 0, h))
    assert gp.full == pytest.approx((p[0], p[1]), abs=1e-6)
    assert gp.err_full <= h * math.tan(gp.tilt) + 1e-6 or h == 0


def test_supervisor_rate_and_timeout():
    s = FollowSupervisor(timeout=1.0, speedup=10.0, rate_hz=10.0)
    due = [s.on_drone_sample(t / 50.0, 0.0) for t in range(0, 51)]   # 50 Hz telemetry, 1 s
    assert sum(due) == 11                                               # 10 Hz ticks
    assert not s.on_drone_sample(0.5, 0.0)                              # old: never drives backwards
    # rover clock live: judged in sim time
    assert not s.stale(wall=0.05, rover_stamp=1.9, rover_wall=0.05)
    assert s.stale(wall=0.05, rover_stamp=2.1, rover_wall=0.05)
    # rover silent too: wall time x speedup (1 s sim = 0.1 s wall at 10x)
    assert not s.stale(wall=0.09)
    assert s.stale(wall=0.11)


@pytest.fixture
def world():
    tport, dport, rport = free_ports(3)
    drone = FakeVehicle(1, dport, name="drone")
    rover = FakeVehicle(2, rport, tl.MAV_TYPE_GROUND_ROVER, name="rover")
    yield tport, dport, rport, drone, rover
    drone.close(); rover.close()


def _start(world, **kw):
    tport, dport, rport, drone, rover = world
    cfg = bridge_config(tport, dport, rport, **kw)
    return cfg


def fly(drone, rover, t0_ms, n, pitch=0.2, yaw=0.0, h=9.0, rover_too=True):
    T = Transform.from_euler(yaw=yaw, pitch=pitch, translation=(10, 5, -h))
    x, y, z, w = T.xyzw
    for k in range(n):
        t = t0_ms + 50 * k
        drone.pose(t, (10, 5, -h), (w, x, y, z), vel=(2.0, 0.5, 0.0))
        if rover_too:
            rover.pose(t, (0, 0, 0))


@pytest.mark.parametrize("frame", ["drone_yaw", "drone"])
def test_follow_loop_goal_mode_and_wobble_figure(world, frame):
    tport, dport, rport, drone, rover = world
    cfg = _start(world, follow=True, follow_frame=frame, follow_offset=(-2.0, 0.0))
    with running_bridge(cfg) as bridge:
        tower = Endpoint(255, 190, tport, listen=False, name="tower")
        try:
            wait_until(lambda: drone.peer and rover.peer, 5, "bridge reaching the vehicles")
            tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            wait_until(lambda: bridge.tower.peers, 5, "tower peer")
            wait_origins(bridge, drone, rover)
            fly(drone, rover, 1000, 21)              # 1 s of telemetry at 20 Hz, pitched 0.2 rad
            goals = wait_until(lambda: len(rover.of_type("SET_POSITION_TARGET_LOCAL_NED")) >= 10 and
                               rover.of_type("SET_POSITION_TARGET_LOCAL_NED"), 5, "10 Hz goals")
            g = goals[-1]
            assert g.get_srcSystem() == 250 and g.coordinate_frame == tl.MAV_FRAME_LOCAL_NED
            assert g.z == 0 and (g.vx, g.vy) == pytest.approx((2.0, 0.5))
            # full attitude, nose up 0.2 rad: the body point (-2, 0, 9) is rotated too
            full_x = 10 - 2 * math.cos(0.2) + 9.0 * math.sin(0.2)
            swing = full_x - 8.0
            want_x = full_x if frame == "drone" else 8.0
            assert (g.x, g.y) == pytest.approx((want_x, 5.0), abs=1e-3)
            # the rover is put in GUIDED and armed
            wait_until(lambda: rover.mode == 15 and rover.armed, 5, "rover GUIDED + armed")
            fs = tower.wait("TOWERLINK_FOLLOW_STATUS")
            assert fs.err_full == pytest.approx(abs(swing), abs=1e-3) and fs.err_yaw == pytest.approx(0, abs=1e-4)
            assert fs.follow_frame == (0 if frame == "drone" else 1)
            assert fs.state == tl.TOWERLINK_FOLLOW_STATE_FOLLOWING
            assert (fs.ref_x, fs.ref_y) == pytest.approx((8.0, 5.0), abs=1e-4)
        finally:
            tower.close()


def test_follow_timeout_holds_then_resumes(world):
    tport, dport, rport, drone, rover = world
    cfg = _start(world, follow=True, follow_timeout=1.0)
    with running_bridge(cfg) as bridge:
        wait_until(lambda: drone.peer and rover.peer, 5, "bridge reaching the vehicles")
        wait_origins(bridge, drone, rover)
        fly(drone, rover, 1000, 5)
        wait_until(lambda: rover.mode == 15, 5, "GUIDED")
        # the drone goes silent; the rover's clock runs on past the timeout
        for k in range(1, 30):
            rover.pose(1200 + 50 * k, (0, 0, 0))
        wait_until(lambda: rover.mode == 4, 5, "rover HOLD after the timeout")
        assert bridge.follower.supervisor.holding
        # once holding, more rover time passes and no goal is sent
        n = len(rover.of_type("SET_POSITION_TARGET_LOCAL_NED"))
        for k in range(30, 50):
            rover.pose(1200 + 50 * k, (0, 0, 0))
        wait_until(lambda: (bridge.timeline.newest("rover")[0] or 0) >= (1200 + 50 * 49) / 1000, 5,
                   "the bridge seeing the rover's later clock")
        tower = Endpoint(255, 190, tport, listen=False, name="tower")
        try:
            sync(tower, rover)          # whatever the bridge sent the rover so far has arrived
        finally:
            tower.close()
        assert bridge.follower.supervisor.holding
        assert len(rover.of_type("SET_POSITION_TARGET_LOCAL_NED")) == n
        # telemetry returns: GUIDED and goals again
        fly(drone, rover, 3700, 4)
        wait_until(lambda: rover.mode == 15, 5, "GUIDED again")
        wait_until(lambda: len(rover.of_type("SET_POSITION_TARGET_LOCAL_NED")) > n, 5, "goals again")
        assert not bridge.follower.supervisor.holding


@pytest.mark.parametrize("lockstep", [False, True])
def test_in_lockstep_the_rovers_mode_and_arm_go_out_only_at_the_barrier(lockstep):
    # a drone sample is handled mid-frame, before or after the rover's own packets of that frame
    # (arrival order across links); with lockstep what the follower commands the rover besides
    # its setpoint must wait for the barrier, when the rover's state up to t is all read
    from types import SimpleNamespace

    from bridge.follower import Follower
    from common.frames import Buffer, TransformStamped
    from common.mavlink.modes import ROVER_GUIDED
    cfg = bridge_config(free_ports(1)[0], lockstep=lockstep)
    buf = Buffer()
    for parent, child in (("world", "drone"), ("world", "drone_yaw"), ("rover_origin", "world")):
        buf.set_transform_static(TransformStamped(parent, child, 0.0, Transform((1.0, 2.0, -9.0))))
    f = Follower(cfg, buf, lambda: 5.0, lambda line: None, lambda key, line: None)
    rover = SimpleNamespace(name="rover", sysid=2, custom_mode=4, armed=False, last_heartbeat_wall=1.0,
                            position=None)
    sample = [(d, m.get_type()) for d, m in f.on_drone_sample(5.0, (0.0, 0.0, 0.0), False, rover)]
    assert ("rover", "SET_POSITION_TARGET_LOCAL_NED") in sample
    commands = [m.command for d, m in f.check(rover, 5.0, 1.0) if m.get_type() == "COMMAND_LONG"]
    if lockstep:
        assert [t for _, t in sample if t == "COMMAND_LONG"] == []
        assert commands == [tl.MAV_CMD_DO_SET_MODE, tl.MAV_CMD_COMPONENT_ARM_DISARM]   # at the barrier
    else:
        assert [t for _, t in sample].count("COMMAND_LONG") == 2 and commands == []   # sent at once
    assert f.mode_wanted == ROVER_GUIDED
