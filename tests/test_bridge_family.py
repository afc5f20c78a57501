"""Issue 12 in the bridge: a family of vehicles, one follower per pair, goals at their stamp.

Real sockets: the bridge runs on a thread, the vehicles and the tower are fakes on
loopback UDP (tests/bridge_fakes.py).
"""
from __future__ import annotations

import contextlib
import math

import pytest

from common.mavlink.dialect import towerlink as tl
from common.frames import Transform
from common.scenario import parse_static_transform
from bridge.config import BridgeConfig
from bridge_fakes import Endpoint, FakeVehicle, running_bridge, sync, wait_origins
from support import free_ports, wait_until


@contextlib.contextmanager
def family(vehicles, pairs=(), statics=(), follow=False):
    """A bridge serving fake vehicles [(name, sysid, mav_type)]; yields (bridge, tower, {name: fake})."""
    ports = free_ports(len(vehicles) + 1)
    fakes = {name: FakeVehicle(sysid, port, mav_type, name=name)
             for (name, sysid, mav_type), port in zip(vehicles, ports[1:])}
    cfg = BridgeConfig(tower=f"udpin:127.0.0.1:{ports[0]}", drone=None, rover=None, quiet=True,
                       vehicles=[(name, f"udpout:127.0.0.1:{port}", sysid)
                                 for (name, sysid, _t), port in zip(vehicles, ports[1:])],
                       pairs=list(pairs), follow=follow, time_grace=0.05,
                       statics=[parse_static_transform(s) for s in statics])
    with running_bridge(cfg) as bridge:
        tower = Endpoint(255, 190, ports[0], listen=False, name="tower")
        try:
            wait_until(lambda: all(f.peer for f in fakes.values()), 5, "bridge reaching the vehicles")
            wait_origins(bridge, *fakes.values())   # else the first poses have no place in world
            tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            wait_until(lambda: bridge.tower.peers, 5, "tower peer known")
            yield bridge, tower, fakes
        finally:
            for e in (tower, *fakes.values()):
                e.close()


COPTER, ROVER = tl.MAV_TYPE_QUADROTOR, tl.MAV_TYPE_GROUND_ROVER


def test_each_rover_follows_its_own_drone_and_goals_go_to_their_target():
    vehicles = [("drone1", 1, COPTER), ("drone2", 2, COPTER), ("rover1", 3, ROVER), ("rover2", 4, ROVER)]
    with family(vehicles, pairs=[(1, 3), (2, 4)], statics=["100 0 0 0 0 0 world tower"],
                follow=True) as (bridge, tower, v):
        # two drones far apart, each yawed differently; the rovers somewhere else
        q2 = Transform.from_euler(yaw=math.pi / 2).xyzw
        for k in range(6):
            t = 1000 + 100 * k
            v["drone1"].pose(t, (10.0, 0.0, -5.0))
            v["drone2"].pose(t, (0.0, 20.0, -8.0), (q2[3], q2[0], q2[1], q2[2]))
            v["rover1"].pose(t, (-3.0, 0.0, 0.0))
            v["rover2"].pose(t, (-3.0, 2.0, 0.0))
        r1 = v["rover1"].wait("SET_POSITION_TARGET_LOCAL_NED")
        r2 = v["rover2"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (r1.target_system, r1.x, r1.y, r1.z) == (3, pytest.approx(10.0, abs=1e-4), pytest.approx(0.0, abs=1e-4), 0.0)
        assert (r2.target_system, r2.x, r2.y, r2.z) == (4, pytest.approx(0.0, abs=1e-4), pytest.approx(20.0, abs=1e-4), 0.0)
        # nothing of one pair reached the other's rover
        assert all(m.target_system == 3 for m in v["rover1"].of_type("SET_POSITION_TARGET_LOCAL_NED"))
        assert all(m.target_system == 4 for m in v["rover2"].of_type("SET_POSITION_TARGET_LOCAL_NED"))
        # every vehicle's frames are in the tree
        for f in ("drone1", "drone1_yaw", "drone2", "drone2_yaw", "rover1", "rover2_yaw"):
            wait_until(lambda: bridge.buffer.can_transform("world", f), 5, f"world -> {f}")
        # a tower goal (tower frame) goes to its target drone only, translated to world
        tower.mav.set_position_target_local_ned_send(1500, 2, 1, tl.MAV_FRAME_LOCAL_NED, 0b1111_1111_1000,
                                                     5.0, 6.0, -10.0, 0, 0, 0, 0, 0, 0, 0, 0)
        m = v["drone2"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (m.x, m.y, m.z) == pytest.approx((105.0, 6.0, -10.0), abs=1e-4)
        sync(tower, v["drone1"])
        assert not v["drone1"].of_type("SET_POSITION_TARGET_LOCAL_NED")


def van_pose(van, t_ms: int) -> None:
    """The van drives north at 10 m/s from the origin, facing north."""
    van.pose(t_ms, (10.0 * (t_ms / 1000.0 - 1.0), 0.0, 0.0), vel=(10.0, 0.0, 0.0))


def test_goal_in_the_vans_tower_frame_is_resolved_at_its_stamp_not_the_latest():
    vehicles = [("drone", 1, COPTER), ("van", 2, ROVER)]
    with family(vehicles, statics=["0 0 0 0 0 0 van tower"]) as (bridge, tower, v):
        for t in range(1000, 3001, 100):                  # van at x = 0 .. 20 m
            van_pose(v["van"], t)
            v["drone"].pose(t, (0.0, 0.0, -9.0))
        wait_until(lambda: bridge.buffer.can_transform("world", "tower", 3.0), 5, "van at t=3 s")
        # the tower spoke at t = 2 s (van at x = 10): 5 m ahead of it is x = 15, not 25
        tower.mav.set_position_target_local_ned_send(2000, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b1111_1111_1000,
                                                     5.0, 0.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
        m = v["drone"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (m.x, m.y, m.z) == pytest.approx((15.0, 0.0, -9.0), abs=1e-3)
        assert m.time_boot_ms == 2000
        # the difference to the latest transform (van at x = 20) is logged and kept
        assert bridge.goals.time_travel[-1][0] == 1 and bridge.goals.time_travel[-1][2] == pytest.approx(10.0, abs=1e-3)
        assert any("resolved at its stamp 2.000 s" in line and "10.00 m away" in line for line in bridge.logs)
        # the van drives on past the buffer's window; a re-send with the same stamp lands
        # on the same world point
        for t in range(3100, 15001, 100):
            van_pose(v["van"], t)
            v["drone"].pose(t, (0.0, 0.0, -9.0))
        wait_until(lambda: bridge.buffer.can_transform("world", "tower", 15.0), 5, "van at t=15 s")
        v["drone"].clear()
        tower.mav.set_position_target_local_ned_send(2000, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b1111_1111_1000,
                                                     5.0, 0.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
        m = v["drone"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (m.x, m.y, m.z) == pytest.approx((15.0, 0.0, -9.0), abs=1e-3)
        # a goal stamped ahead of the van's newest sample waits for it, then uses it
        v["drone"].clear()
        tower.mav.set_position_target_local_ned_send(15500, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b1111_1111_1000,
                                                     0.0, 3.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
        wait_until(lambda: bridge.tower.stats.deferred >= 2, 5, "goal waiting for the van")
        sync(tower, v["drone"])
        assert not v["drone"].of_type("SET_POSITION_TARGET_LOCAL_NED")
        for t in range(15100, 16001, 100):
            van_pose(v["van"], t)
            v["drone"].pose(t, (0.0, 0.0, -9.0))
        m = v["drone"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (m.x, m.y, m.z) == pytest.approx((145.0, 3.0, -9.0), abs=1e-3)


def test_goal_in_a_static_tower_frame_ignores_the_stamp():
    vehicles = [("drone", 1, COPTER)]
    with family(vehicles, statics=["100 0 0 0 0 0 world tower"]) as (bridge, tower, v):
        v["drone"].pose(1000, (0.0, 0.0, -9.0))
        tower.mav.set_position_target_local_ned_send(999999, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b1111_1111_1000,
                                                     1.0, 2.0, -9.0, 0, 0, 0, 0, 0, 0, 0, 0)
        m = v["drone"].wait("SET_POSITION_TARGET_LOCAL_NED")
        assert (m.x, m.y, m.z) == pytest.approx((101.0, 2.0, -9.0), abs=1e-4)
        assert not bridge.goals.time_travel
