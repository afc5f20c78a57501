"""The mission glue on a real in-process world over UDP: MISSION_ITEM_REACHED from the
autopilot's item_reached hook, MISSION_CURRENT streamed in SR0_EXT_STAT with total and
mission_state, MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT routed to set_mission_current,
an upload reaching the autopilot's mission_uploaded hook."""
from __future__ import annotations

import pytest

from support import free_port
from test_sitl_support import command, connect, mav, recv, set_mode, wait_armable
from vehicle.autopilot.mission_store import MISSION, MissionItem
from vehicle.world import World, WorldConfig


@pytest.fixture
def world():
    port = free_port()
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None,
                          endpoints={0: [f"udpin:127.0.0.1:{port}"]}))
    w.port = port
    w.start_thread()
    try:
        yield w
    finally:
        w.stop()


def test_reached_current_and_set_current(world):
    ap = world.vehicles[0].ap
    calls = []
    ap.set_mission_current = lambda seq: calls.append(seq) or seq == 2      # a runner that knows seq 2
    ap.mission_uploaded = lambda t: calls.append(("uploaded", t))
    m = connect(world.port)
    items = [MissionItem(seq=i, frame=6, command=16, x=-353632610 + 100 * i, y=1491652300, z=10.0) for i in range(4)]
    m.mav.mission_count_send(1, 1, 4, 0)
    for _ in range(4):
        r = recv(m, "MISSION_REQUEST_INT", 5)
        it = items[r.seq]
        m.mav.mission_item_int_send(1, 1, it.seq, it.frame, it.command, 0, 1, 0, 0, 0, 0, it.x, it.y, it.z, 0)
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_ACCEPTED
    assert ("uploaded", MISSION) in calls
    cur = recv(m, "MISSION_CURRENT", 5)
    assert (cur.seq, cur.total, cur.mission_state, cur.mission_mode) == (0, 3, mav.MISSION_STATE_NOT_STARTED, 0)
    world._loop.call_soon_threadsafe(ap.item_reached, 3)
    assert recv(m, "MISSION_ITEM_REACHED", 5).seq == 3
    m.mav.mission_set_current_send(1, 1, 2)
    recv(m, "MISSION_CURRENT", 5)
    assert 2 in calls
    assert command(m, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 2) == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == mav.MAV_RESULT_FAILED
    assert calls.count(2) == 2 and 1 in calls


def test_guided_fly_to_item_current_2(world):
    """MISSION_ITEM_INT with current = 2 (MAVProxy `guided`, Mission Planner Fly To Here) sets
    the GUIDED target, as ArduPilot's handle_guided_request; ERROR outside GUIDED."""
    ap = world.vehicles[0].ap
    m = connect(world.port)
    lat, lon = -353632610 + 900, 1491652300          # ~10 m north of home

    def fly_to():
        m.mav.mission_item_int_send(1, 1, 0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_WAYPOINT,
                                    2, 1, 0, 0, 0, 0, lat, lon, 12.0, 0)
        return recv(m, "MISSION_ACK", 5).type

    assert fly_to() == mav.MAV_MISSION_ERROR                   # STABILIZE: refused
    assert ap.guided.targets.target is None
    wait_armable(m)                                            # GUIDED needs a position estimate
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert fly_to() == mav.MAV_MISSION_ACCEPTED
    tgt = ap.guided.targets.target
    assert tgt is not None and tgt.pos[0] == pytest.approx(10.0, abs=0.2) and tgt.pos[1] == pytest.approx(0.0, abs=0.2)
    assert -tgt.pos[2] == pytest.approx(12.0, abs=0.5)
    assert ap.missions.count() == 0                            # not a mission item
    m.mav.mission_item_int_send(1, 1, 0, mav.MAV_FRAME_LOCAL_NED, 16, 2, 1, 0, 0, 0, 0, lat, lon, 12.0, 0)
    assert recv(m, "MISSION_ACK", 5).type == mav.MAV_MISSION_UNSUPPORTED_FRAME
