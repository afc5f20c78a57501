"""A pymavlink script under test: arm, take off to 10 m, fly 50 m north, land.

The towerlink_sitl fixture (towerlink's pytest plugin, installed with towerlink) starts a
world on free ports, already past start-up (position estimate, home, EKF origin), and stops it
afterwards. The script talks to it as to ArduPilot SITL; the assertions use the vehicle's
truth (sitl.vehicle(0): world NED from the origin, m, z down) and wait in sim seconds.

    pytest examples/pytest/test_pymavlink_flight.py
"""
import pytest
from pymavlink import mavutil

mav = mavutil.mavlink
POSITION_ONLY = 0b110111111000          # SET_POSITION_TARGET_LOCAL_NED: use x, y, z only


def takeoff_fly_land(conn: str, north: float, alt: float) -> mavutil.mavfile:
    """The script under test, as written for ArduPilot: GUIDED, arm, NAV_TAKEOFF, a local
    NED position target, LAND. It sends and returns; the test watches the vehicle."""
    m = mavutil.mavlink_connection(conn, source_system=255)
    m.wait_heartbeat(timeout=5)
    m.set_mode("GUIDED")
    m.arducopter_arm()
    m.motors_armed_wait()
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_NAV_TAKEOFF, 0,
                            0, 0, 0, 0, 0, 0, alt)
    return m


def goto(m: mavutil.mavfile, north: float, east: float, down: float) -> None:
    m.mav.set_position_target_local_ned_send(0, m.target_system, m.target_component, mav.MAV_FRAME_LOCAL_NED,
                                             POSITION_ONLY, north, east, down, 0, 0, 0, 0, 0, 0, 0, 0)


@pytest.mark.towerlink(drones=1, speedup="max")
def test_takeoff_fly_50m_north_land(towerlink_sitl):
    sitl = towerlink_sitl
    m = takeoff_fly_land(sitl.connection(0), north=50.0, alt=10.0)
    sitl.wait_for(lambda: sitl.vehicle(0).height > 9.5, sim_timeout=20, what="10 m")
    goto(m, 50.0, 0.0, -10.0)
    sitl.wait_for(lambda: sitl.vehicle(0).distance_to(50.0, 0.0, -10.0) < 1.0, sim_timeout=40, what="50 m north")
    m.set_mode("LAND")
    sitl.wait_for(lambda: not sitl.vehicle(0).armed, sim_timeout=60, what="landed and disarmed")
    v = sitl.vehicle(0)
    assert v.landed and v.mode == "LAND"
    assert abs(v.north - 50.0) < 1.5 and abs(v.east) < 1.5 and v.height < 0.3
    m.close()
