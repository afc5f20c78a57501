"""Each vehicle's own EKF origin (issue 10): local NED centred where the vehicle booted,
GPS_GLOBAL_ORIGIN on request and when set, SET_GPS_GLOBAL_ORIGIN as ArduPilot handles it.

The world puts the rover 3 m south of the drone (vehicle.world.World.start_position); GPS
noise is 0.3 m (1 sigma) horizontally, so positions are compared within 1 m.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from common import geo
from vehicle.autopilot.ekf_origin import EkfOrigin
from test_sitl_support import Sitl, command, connect, goto_local, mav, recv, set_mode, wait_armable

GPS_TOL = 1.0          # m: 3 sigma of the simulated GPS's 0.3 m, the origin's own error included


def origin_of(m):
    assert command(m, mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN) == mav.MAV_RESULT_ACCEPTED
    o = recv(m, "GPS_GLOBAL_ORIGIN")
    return o.latitude * 1e-7, o.longitude * 1e-7, o.altitude * 1e-3


def test_origin_is_set_once_and_converts_both_ways():
    home = (-35.363261, 149.165230, 584.0)
    o = EkfOrigin(home)
    assert not o.is_set
    assert not o.set(91.0, 0.0, 0.0) and not o.set(float("nan"), 0.0, 0.0)
    lat, lon, alt = geo.ned_to_lla(home, (-3.0, 4.0, 0.0))
    assert o.set(lat, lon, alt)
    first = o.lla
    assert not o.set(*home) and o.lla == first            # a second origin is ignored
    # held to 1e-7 deg and 1 cm, as ArduPilot's Location: within 1.1 cm of the asked place
    assert np.allclose(o.offset, (-3.0, 4.0, 0.0), atol=0.012)
    assert np.allclose(o.offset, geo.lla_to_ned(home, *o.lla), atol=1e-9)
    assert o.lla[0] * 1e7 == pytest.approx(round(o.lla[0] * 1e7), abs=1e-6)
    assert np.allclose(o.to_local(o.offset + (0, 0, -2.0)), (0.0, 0.0, -2.0), atol=1e-9)
    assert np.allclose(o.to_world(o.to_local((7.0, -1.0, 3.0))), (7.0, -1.0, 3.0))


@pytest.fixture
def sitl(processes, tmp_path):
    return Sitl(processes, tmp_path, drones=1, rovers=1, speedup=10.0)


def test_rover_reports_its_own_origin_and_local_zero_at_its_start(sitl):
    drone, rover = connect(sitl.udp[0]), connect(sitl.udp[1])
    wait_armable(drone)
    wait_armable(rover)
    d0, r0 = origin_of(drone), origin_of(rover)
    # where the rover's origin is, seen from the drone's: its start 3 m south, within GPS noise
    n, e, d = geo.lla_to_ned(d0, *r0)
    assert math.hypot(n - -3.0, e) < GPS_TOL and abs(d) < 2.0
    # each reports its own local (0, 0) at its start, and truth agrees through its own origin
    for m, o in ((drone, d0), (rover, r0)):
        p = recv(m, "LOCAL_POSITION_NED")
        assert math.hypot(p.x, p.y) < GPS_TOL, (p.x, p.y)
        s = recv(m, "SIM_STATE")
        tn, te, _ = geo.lla_to_ned(o, s.lat_int * 1e-7, s.lon_int * 1e-7, s.alt)
        assert math.hypot(tn - p.x, te - p.y) < GPS_TOL
        h = recv(m, "HOME_POSITION")
        assert math.hypot(h.x, h.y) < GPS_TOL          # home in the local frame, beside its origin
    # SET_GPS_GLOBAL_ORIGIN after the first fix is ignored, silently, as ArduPilot
    rover.mav.set_gps_global_origin_send(2, int(r0[0] * 1e7) + 1000, int(r0[1] * 1e7), int(r0[2] * 1000), 0)
    assert origin_of(rover) == pytest.approx(r0, abs=1e-7)


def test_rover_local_target_is_from_its_own_origin(sitl):
    rover = connect(sitl.udp[1])
    wait_armable(rover)
    r0 = origin_of(rover)
    assert set_mode(rover, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert command(rover, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    for _ in range(3):
        goto_local(rover, 6.0, 0.0, 0.0)
    t = recv(rover, "POSITION_TARGET_LOCAL_NED", cond=lambda t: abs(t.x - 6.0) < 1e-3)
    assert abs(t.y) < 1e-3                              # echoed in the same local frame
    recv(rover, "LOCAL_POSITION_NED", timeout=30, cond=lambda p: math.hypot(p.x - 6.0, p.y) < 0.5)
    s = recv(rover, "SIM_STATE")
    world = geo.lla_to_ned(geo.ned_to_lla((-35.363261, 149.165230, 584.0), (0, 0, 0)),
                           s.lat_int * 1e-7, s.lon_int * 1e-7, s.alt)
    # 6 m north of the rover's own start (world -3, 0) is world (3, 0), not world (6, 0)
    assert math.hypot(world[0] - 3.0, world[1]) < GPS_TOL, world
    assert math.hypot(*geo.lla_to_ned(r0, s.lat_int * 1e-7, s.lon_int * 1e-7, s.alt)[:2]) > 5.0


def test_bridge_world_to_rover_matches_truth_for_a_rover_booted_3m_away(sitl):
    """The real SITL vehicles and the bridge: world -> rover (through rover_origin, from the
    rover's GPS_GLOBAL_ORIGIN) puts the rover where its truth (SIM_STATE) is in world."""
    from bridge_fakes import bridge_config, running_bridge
    from support import free_port, wait_until
    cfg = bridge_config(free_port(), sitl.udp[0], sitl.udp[1], follow=False)
    with running_bridge(cfg) as bridge:
        wait_until(lambda: bridge.origins.known("drone") and bridge.origins.known("rover")
                   and bridge.buffer.can_transform("world", "rover"), 30, "world -> rover")
        T = bridge.buffer.lookup_transform("world", "rover").transform
        world_lla = bridge.origins.world_origin
    rover = connect(sitl.tcp[1], tcp=True)
    s = recv(rover, "SIM_STATE")
    truth = geo.lla_to_ned(world_lla, s.lat_int * 1e-7, s.lon_int * 1e-7, s.alt)
    # the rover stands still 3 m south of the drone: the bridge agrees with truth within GPS noise
    assert math.hypot(truth[0] - -3.0, truth[1]) < GPS_TOL
    assert math.hypot(T.xyz[0] - truth[0], T.xyz[1] - truth[1]) < GPS_TOL, (T.xyz, truth)
