"""MAVSDK 4.x against issue 10's modes and commands, written as a MAVSDK user writes them:
action.hold() (ArduCopter: BRAKE), offboard start/stop, goto_location (DO_REPOSITION),
telemetry.get_gps_global_origin() (REQUEST_MESSAGE 49), return_to_launch(); each followed by
the flight mode MAVSDK reports. The same against the rover where MAVSDK supports it.

As in test_sitl_mavsdk.py the client runs in its own process (this file as a script) so a hang
in the native library cannot outlive the test; the vehicle pushes to it with --out udpout.
"""
from __future__ import annotations

import math
import sys
import threading

import pytest


# the flight mode MAVSDK reports after each step: its names for ArduCopter's GUIDED, BRAKE,
# RTL and ArduRover's HOLD, GUIDED, RTL
MAVSDK_MODES = {
    "copter": {"armed": "OFFBOARD", "offboard.start": "OFFBOARD", "offboard.stop": "HOLD",
               "goto_location": "OFFBOARD", "hold": "HOLD", "return_to_launch": "RETURN_TO_LAUNCH"},
    "rover": {"armed": "HOLD", "offboard.start": "OFFBOARD", "offboard.stop": "HOLD",
              "goto_location": "OFFBOARD", "hold": "HOLD", "return_to_launch": "RETURN_TO_LAUNCH"},
}


def client(port: int, kind: str) -> int:
    from mavsdk_client import autopilot, wait
    from mavsdk.plugins.action import Action
    from mavsdk.plugins.offboard import Offboard, PositionNedYaw
    from mavsdk.plugins.telemetry import FlightMode, Telemetry

    system = autopilot(port)
    tel, act, off = Telemetry(system), Action(system), Offboard(system)

    def mode(what):
        """Wait until MAVSDK reports the mode a MAVSDK user expects after `what` (a heartbeat
        must carry it), then print what it reports; the test compares (a timeout prints the
        mode MAVSDK kept reporting)."""
        want = MAVSDK_MODES[kind][what]
        try:
            wait(lambda: FlightMode(int(tel.flight_mode())).name == want, 10, f"{want} after {what}")
        except SystemExit:
            pass
        print("MODE", what, FlightMode(int(tel.flight_mode())).name, flush=True)

    def healthy():
        h = tel.health()
        return h.is_global_position_ok and h.is_home_position_ok and h.is_armable
    wait(healthy, 30, "health")
    origin = tel.get_gps_global_origin()
    home = tel.home()
    print(f"ORIGIN {origin.latitude_deg:.7f} {origin.longitude_deg:.7f} {origin.altitude_m:.2f}", flush=True)
    print(f"HOME {home.latitude_deg:.7f} {home.longitude_deg:.7f} {home.absolute_altitude_m:.2f}", flush=True)
    act.arm()
    wait(lambda: tel.armed(), 10, "armed")
    if kind == "copter":
        act.set_takeoff_altitude(5.0)
        act.takeoff()
        wait(lambda: tel.position_velocity_ned().position.down_m < -4.5, 40, "takeoff")
    mode("armed")
    # offboard: start in GUIDED, fly to a point, stop
    p0 = tel.position_velocity_ned().position
    off.set_position_ned(PositionNedYaw(p0.north_m + 8.0, p0.east_m + 4.0, p0.down_m, 0.0))
    off.start()
    mode("offboard.start")

    def near_ned(n, e, tol):
        p = tel.position_velocity_ned().position
        return math.hypot(p.north_m - n, p.east_m - e) < tol
    wait(lambda: near_ned(p0.north_m + 8.0, p0.east_m + 4.0, 1.5), 40, "offboard goal")
    off.stop()
    mode("offboard.stop")
    # goto_location: 20 m north of home, 8 m above it (copter) or on the ground (rover)
    pos = tel.position()
    lat = home.latitude_deg + 20.0 / 111_319.5
    alt = home.absolute_altitude_m + (8.0 if kind == "copter" else 0.0)
    act.goto_location(lat, home.longitude_deg, alt, float("nan"))
    mode("goto_location")

    def arrived():
        q = tel.position()
        dn = (q.latitude_deg - lat) * 111_319.5
        de = (q.longitude_deg - home.longitude_deg) * 111_319.5 * math.cos(math.radians(lat))
        dz = q.absolute_altitude_m - alt if kind == "copter" else 0.0
        return math.sqrt(dn * dn + de * de + dz * dz) < 1.5
    wait(arrived, 60, "goto_location arrival")
    print(f"ARRIVED from {pos.latitude_deg:.7f}", flush=True)
    act.hold()
    mode("hold")
    wait(lambda: tel.velocity_ned().north_m_s ** 2 + tel.velocity_ned().east_m_s ** 2 < 0.04, 20, "held")
    act.return_to_launch()
    mode("return_to_launch")
    if kind == "copter":
        wait(lambda: not tel.armed(), 120, "RTL landed and disarmed")
    else:
        wait(lambda: math.hypot(tel.position().latitude_deg - home.latitude_deg,
                                tel.position().longitude_deg - home.longitude_deg) * 111_319.5 < 3.0, 60,
             "rover home")
    print("MAVSDK OK", flush=True)
    return 0


def _run(processes, tmp_path, kind):
    """As test_sitl_support.run_client_script, plus the vehicle kind for the client and a
    pymavlink listener on the sitl beside it (so it needs the Sitl handle)."""
    from support import free_ports, wait_until
    from test_sitl_support import Sitl
    (port,) = free_ports(1)
    cl = processes.start([sys.executable, __file__, str(port), kind])
    lines: list[str] = []
    threading.Thread(target=lambda: [lines.append(l) for l in cl.stdout], daemon=True).start()
    sitl = Sitl(processes, tmp_path, drones=int(kind == "copter"), rovers=int(kind == "rover"), speedup=5,
                extra=["--out", f"udpout:127.0.0.1:{port}"])
    # beside MAVSDK, a pymavlink listener records the vehicle's own modes (HEARTBEAT custom_mode)
    from test_sitl_support import connect
    m = connect(sitl.udp[0])
    seen: list[int] = []
    while cl.poll() is None:
        hb = m.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        if hb is not None and hb.get_srcSystem() == 1 and (not seen or seen[-1] != hb.custom_mode):
            seen.append(hb.custom_mode)
    wait_until(lambda: cl.poll() is not None, 200, "MAVSDK client to finish")
    out = "".join(lines)
    assert cl.returncode == 0 and "MAVSDK OK" in out, out[-3000:]
    modes = dict(l.split()[1:3] for l in out.splitlines() if l.startswith("MODE"))
    origin = [float(v) for v in next(l for l in out.splitlines() if l.startswith("ORIGIN")).split()[1:]]
    home = [float(v) for v in next(l for l in out.splitlines() if l.startswith("HOME")).split()[1:]]
    return modes, origin, home, seen


@pytest.mark.timeout(220)
def test_mavsdk_copter_hold_offboard_goto_origin_rtl(processes, tmp_path):
    modes, origin, home, seen = _run(processes, tmp_path, "copter")
    # the vehicle's side: STABILIZE, GUIDED (offboard), BRAKE (stop), GUIDED (goto), BRAKE (hold), RTL
    assert seen[-5:] == [4, 17, 4, 17, 6], seen
    # MAVSDK's names for ArduCopter's GUIDED, BRAKE and RTL
    assert modes == MAVSDK_MODES["copter"], modes
    # the EKF origin: where the local NED frame is centred (this world: its origin, the drone's start)
    assert abs(origin[0] - home[0]) * 111_319.5 < 0.5 and abs(origin[1] - home[1]) * 111_319.5 < 0.5


@pytest.mark.timeout(220)
def test_mavsdk_rover_hold_offboard_goto_origin_rtl(processes, tmp_path):
    modes, origin, home, seen = _run(processes, tmp_path, "rover")
    # GUIDED (offboard), HOLD (stop), GUIDED (goto), HOLD, RTL: MAVSDK's Hold is ArduRover's HOLD
    assert seen[-5:] == [15, 4, 15, 4, 11], seen
    assert modes == MAVSDK_MODES["rover"], modes
    # GPS_GLOBAL_ORIGIN answers REQUEST_MESSAGE(49): the rover's own EKF origin, set where it
    # booted (3 m from the drone in this world), metres from home at most
    dn = (origin[0] - home[0]) * 111_319.5
    de = (origin[1] - home[1]) * 111_319.5 * math.cos(math.radians(home[0]))
    assert origin[0] != 0.0 and math.hypot(dn, de) < 50.0


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1]), sys.argv[2]))
