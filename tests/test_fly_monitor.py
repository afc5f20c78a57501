"""fly's Monitor over loopback UDP: it asks the drone, not whoever sent last, for the scoring
parameters (every vehicle pushes to its one "vehicles" socket, each from its own address)."""
from __future__ import annotations

import socket

from common.mavlink.dialect import towerlink as tl
from support import free_ports, wait_until
from tools.fly_monitor import Monitor
from tools.run_data import DRONE, ROVER
from tools.run_figures import SCORING_PARAMS


def _vehicle(sysid: int):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.5)
    return s, tl.MAVLink(None, srcSystem=sysid, srcComponent=1)


def _received(s) -> list:
    p, out = tl.MAVLink(None), []
    while True:
        try:
            data = s.recv(65535)
        except socket.timeout:
            return out
        out += [m for m in p.parse_buffer(data) or [] if m.get_type() == "PARAM_REQUEST_READ"]


def test_scoring_parameters_are_asked_of_the_drone_even_when_the_rover_sent_last(tmp_path):
    vport, bport = free_ports(2)
    mon = Monitor(tmp_path, {"vehicles": vport, "bridge": bport})
    mon.start()
    (drone, dmav), (rover, rmav) = _vehicle(DRONE), _vehicle(ROVER)
    try:
        for s, mav, t in ((drone, dmav, tl.MAV_TYPE_QUADROTOR), (rover, rmav, tl.MAV_TYPE_GROUND_ROVER)):
            s.sendto(tl.MAVLink_heartbeat_message(t, 3, 0, 0, 0, 3).pack(mav), ("127.0.0.1", vport))
        wait_until(lambda: ("vehicles", ROVER) in mon.addr_of and ("vehicles", DRONE) in mon.addr_of,
                   5, "both vehicles heard")
        mon.request_params()
        asked = _received(drone)
        assert sorted(m.param_id for m in asked) == sorted(SCORING_PARAMS)
        assert all(m.target_system == DRONE for m in asked) and _received(rover) == []
        # an answer is kept; the next round asks only for what is still missing
        drone.sendto(tl.MAVLink_param_value_message(b"WPNAV_SPEED", 450.0, tl.MAV_PARAM_TYPE_REAL32, 3, 0)
                     .pack(dmav), ("127.0.0.1", vport))
        wait_until(lambda: mon.params.get("WPNAV_SPEED") == 450.0, 5, "PARAM_VALUE tracked")
        mon.request_params()
        assert sorted(m.param_id for m in _received(drone)) == ["PSC_JERK_XY", "WPNAV_ACCEL"]
    finally:
        mon.stop()
        mon.join(2)
        drone.close()
        rover.close()
