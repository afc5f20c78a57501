"""The bridge's world -> <vehicle>_origin edges (issue 10): vehicles that booted in different
places report LOCAL_POSITION_NED in their own frames; GPS_GLOBAL_ORIGIN puts them in one world."""
from __future__ import annotations

import math

import pytest

from common import geo
from common.mavlink.dialect import towerlink as tl
from common.frames import ConnectivityException
from bridge.origins import OriginDesk, origin_from_message
from bridge_fakes import FakeVehicle, bridge_config, bridge_with_fakes, running_bridge
from support import free_ports, wait_until

HOME = (-35.363261, 149.165230, 584.0)


def test_origin_desk_world_waits_for_the_reference_vehicle():
    d = OriginDesk("world", None, reference="drone")
    rover_lla = geo.ned_to_lla(HOME, (-3.0, 1.0, 0.5))
    assert d.on_origin("rover", rover_lla) == [] and not d.known("rover")
    edges = {e.child_frame_id: e for e in d.on_origin("drone", HOME)}
    assert set(edges) == {"drone_origin", "rover_origin"}
    assert edges["drone_origin"].transform.xyz == pytest.approx((0, 0, 0), abs=1e-9)
    assert edges["rover_origin"].transform.xyz == pytest.approx((-3.0, 1.0, 0.5), abs=1e-6)
    assert d.on_origin("rover", rover_lla) == []             # unchanged: nothing to republish
    assert d.wanted("x", 0.0) and not d.wanted("x", 0.5) and d.wanted("x", 1.1)
    assert not d.wanted("rover", 5.0)


def test_origin_from_message_refuses_non_places():
    ok = tl.MAVLink_gps_global_origin_message(int(HOME[0] * 1e7), int(HOME[1] * 1e7), 584000, 0)
    assert origin_from_message(ok) == pytest.approx(HOME, abs=1e-6)
    assert origin_from_message(tl.MAVLink_gps_global_origin_message(int(91e7), 0, 0, 0)) is None


def test_rover_booted_3m_away_lands_in_world_and_gets_targets_in_its_own_frame():
    # it booted 3 m south of the drone (an origin is 1e-7 deg: about 1 cm, as ArduPilot's Location)
    rover_origin = tuple(round(v, 7) for v in geo.ned_to_lla(HOME, (-3.0, 0.0, 0.0)))
    south = geo.lla_to_ned(HOME, *rover_origin)[0]
    assert south == pytest.approx(-3.0, abs=0.011)
    with bridge_with_fakes(follow=True, follow_offset=(0.0, 0.0), origins={"rover": rover_origin}) as f:
        bridge, tower, drone, rover = f["bridge"], f["tower"], f["drone"], f["rover"]
        for k in range(21):                # the rover at its own local (0, 0), the drone hovering
            rover.pose(1000 + 50 * k, (0.0, 0.0, 0.0))
        wait_until(lambda: bridge.vehicles[2].position is not None, 5, "rover position")
        for k in range(21):
            drone.pose(1000 + 50 * k, (4.0, 2.0, -9.0))
        wait_until(lambda: bridge.buffer.can_transform("world", "rover") and bridge.buffer.can_transform("world", "drone"),
                   5, "world -> rover, drone")
        T = bridge.buffer.lookup_transform("world", "rover")
        assert T.transform.xyz == pytest.approx((south, 0.0, 0.0), abs=1e-6)
        assert bridge.buffer.lookup_transform("world", "drone").transform.xyz == \
            pytest.approx((4.0, 2.0, -9.0), abs=1e-3)
        # the ground point under the drone is world (4, 2): the rover's own (7, 2)
        g = wait_until(lambda: rover.of_type("SET_POSITION_TARGET_LOCAL_NED"), 5, "follow goal")[-1]
        assert (g.x, g.y) == pytest.approx((4.0 - south, 2.0), abs=1e-4)
        # the follow status (world) has the rover where it is in world
        fs = tower.wait("TOWERLINK_FOLLOW_STATUS", lambda m: math.isfinite(m.rover_x))
        assert (fs.rover_x, fs.rover_y) == pytest.approx((south, 0.0), abs=1e-4)
        # the tower sees the static edge on the stream
        m = tower.wait("TOWERLINK_TRANSFORM", lambda m: m.child_frame_id == "rover_origin")
        assert m.flags & 1 and m.frame_id == "world" and m.translation[0] == pytest.approx(south, abs=1e-5)


def test_without_an_origin_the_vehicle_is_not_in_world():
    tport, dport = free_ports(2)
    drone = FakeVehicle(1, dport, name="drone")
    drone.origin = None                                          # never answers GPS_GLOBAL_ORIGIN
    try:
        with running_bridge(bridge_config(tport, dport, None, follow=False)) as bridge:
            wait_until(lambda: drone.peer, 5, "bridge reaching the drone")
            drone.heartbeat()
            for k in range(5):
                drone.pose(1000 + 50 * k, (1.0, 2.0, -3.0))
            wait_until(lambda: bridge.buffer.can_transform("drone_origin", "drone"), 5, "drone edge")
            with pytest.raises(ConnectivityException):
                bridge.buffer.lookup_transform("world", "drone")
            # and it was asked for one
            drone.wait("COMMAND_LONG", lambda m: m.command == tl.MAV_CMD_REQUEST_MESSAGE and m.param1 == 49)
    finally:
        drone.close()
