"""MAVSDK 4.x (the native `mavsdk` wheel) flies the SITL drone: discovery, health, arm,
takeoff, Offboard position NED to a point (GUIDED on ArduPilot), land.

The MAVSDK client runs in its own process (this file run as a script), so a hang in the
native library cannot outlive the test: the `processes` fixture kills it at teardown.
The vehicle pushes to it with --out udpout:127.0.0.1:PORT; MAVSDK listens on udpin.
"""
from __future__ import annotations

import sys

import pytest


def client(port: int) -> int:
    from mavsdk_client import autopilot, land_and_finish, step, wait
    from mavsdk.plugins.action import Action
    from mavsdk.plugins.offboard import Offboard, PositionNedYaw
    from mavsdk.plugins.telemetry import Telemetry

    system = autopilot(port)
    tel, act, off = Telemetry(system), Action(system), Offboard(system)

    def healthy():
        h = tel.health()
        return h.is_global_position_ok and h.is_local_position_ok and h.is_home_position_ok and h.is_armable
    wait(healthy, 30, "health")
    step("health ok")
    act.arm()
    wait(lambda: tel.armed(), 10, "armed")
    step("armed")
    act.set_takeoff_altitude(5.0)
    act.takeoff()
    wait(lambda: tel.position_velocity_ned().position.down_m < -4.5, 40, "takeoff")
    step("took off")
    off.set_position_ned(PositionNedYaw(6.0, 4.0, -5.0, 0.0))
    off.start()
    def there():
        p = tel.position_velocity_ned().position
        return ((p.north_m - 6) ** 2 + (p.east_m - 4) ** 2 + (p.down_m + 5) ** 2) ** 0.5 < 0.5
    wait(there, 40, "offboard goal")
    step("goal reached")
    try:
        off.stop()
    except Exception:
        pass
    return land_and_finish(act, tel)


@pytest.mark.timeout(150)
def test_mavsdk_flight(processes, tmp_path):
    from test_sitl_support import run_client_script
    run_client_script(processes, tmp_path, __file__, "MAVSDK OK", speedup=5)


if __name__ == "__main__":
    sys.exit(client(int(sys.argv[1])))
