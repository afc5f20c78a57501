"""Missions under test: a pymavlink upload flown in AUTO, and a mission the world starts with.

The upload is MAVLink's mission protocol as a script speaks it (MISSION_COUNT, then one
MISSION_ITEM_INT per MISSION_REQUEST_INT, then MISSION_ACK). The marker's ``mission=`` loads
a QGC WPL 110 file into vehicle 0 at start instead, as ``towerlink sitl --mission 0=FILE``.

    pytest examples/pytest/test_mission.py
"""
from pathlib import Path

import pytest
from pymavlink import mavutil

from common import geo   # towerlink's own helper: NED metres from the world origin <-> lat/lon

mav = mavutil.mavlink
HOME = (-35.363261, 149.165230, 584.0)       # the world's origin (the marker's default home)
SQUARE = Path(__file__).with_name("square.waypoints")
REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def item(seq: int, command: int, north: float = 0.0, east: float = 0.0, alt: float = 0.0):
    lat, lon, _ = geo.ned_to_lla(HOME, (north, east, 0.0))
    return mav.MAVLink_mission_item_int_message(1, 1, seq, REL, command, 0, 1, 0, 0, 0, 0,
                                                int(round(lat * 1e7)), int(round(lon * 1e7)), alt)


def upload(m, items, timeout: float = 5.0) -> int:
    """The mission protocol's upload; returns the final MISSION_ACK's result.

    The vehicle asks again for an item it has not got within its timeout (sim time: at a high
    speedup that is a few wall milliseconds), so an answer may cross a repeated request: the
    vehicle then says INVALID_SEQUENCE for the late duplicate and the upload goes on."""
    m.mav.mission_count_send(m.target_system, m.target_component, len(items))
    while True:
        msg = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True,
                           timeout=timeout)
        assert msg is not None, "no answer to the mission upload"
        if msg.get_type() == "MISSION_ACK":
            if msg.type == mav.MAV_MISSION_INVALID_SEQUENCE:
                continue
            return msg.type
        it = items[msg.seq]
        it.target_system, it.target_component = m.target_system, m.target_component
        m.mav.send(it)


def download_count(m, timeout: float = 5.0) -> int:
    m.mav.mission_request_list_send(m.target_system, m.target_component)
    msg = m.recv_match(type="MISSION_COUNT", blocking=True, timeout=timeout)
    assert msg is not None, "no MISSION_COUNT"
    m.mav.mission_ack_send(m.target_system, m.target_component, mav.MAV_MISSION_ACCEPTED)
    return msg.count


@pytest.mark.towerlink(drones=1, speedup="max")
def test_uploaded_mission_flies_in_auto(towerlink_sitl):
    sitl = towerlink_sitl
    m = mavutil.mavlink_connection(sitl.connection(0), source_system=255)
    m.wait_heartbeat(timeout=5)
    mission = [item(0, mav.MAV_CMD_NAV_WAYPOINT),                  # home (ArduPilot ignores it)
               item(1, mav.MAV_CMD_NAV_TAKEOFF, alt=8.0),
               item(2, mav.MAV_CMD_NAV_WAYPOINT, 15.0, 0.0, 8.0),
               item(3, mav.MAV_CMD_NAV_WAYPOINT, 15.0, 15.0, 8.0),
               item(4, mav.MAV_CMD_NAV_LAND, 15.0, 15.0)]                # lands there
    assert upload(m, mission) == mav.MAV_MISSION_ACCEPTED
    assert download_count(m) == len(mission)
    m.set_mode("GUIDED")
    m.arducopter_arm()
    m.motors_armed_wait()
    m.set_mode("AUTO")
    # on the ground with no RC throttle, ArduCopter starts an AUTO mission on MISSION_START
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_MISSION_START, 0, 0, 0, 0, 0, 0, 0, 0)
    sitl.wait_for(lambda: sitl.vehicle(0).distance_to(15.0, 0.0) < 1.0 and sitl.vehicle(0).height > 7,
                  sim_timeout=40, what="waypoint 2")
    sitl.wait_for(lambda: not sitl.vehicle(0).armed, sim_timeout=60, what="the mission's landing")
    v = sitl.vehicle(0)
    assert v.landed and v.distance_to(15.0, 15.0) < 1.5
    m.close()


@pytest.mark.towerlink(drones=1, mission=SQUARE)
def test_world_starts_with_the_marker_mission(towerlink_sitl):
    m = mavutil.mavlink_connection(towerlink_sitl.connection(0), source_system=255)
    m.wait_heartbeat(timeout=5)
    assert download_count(m) == 5            # the file's 5 lines, home included
    m.close()
