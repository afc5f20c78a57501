"""A MAVSDK-Python 4.x script under test (the native API: ``Mavsdk``, plugins built on a
System): take off, fly an Offboard position, land. 4.x is what ``pip install mavsdk`` gives.

``towerlink_sitl.mavsdk_address(0)`` is ``tcpout://127.0.0.1:PORT``: MAVSDK connects to the
vehicle's TCP port, as to ArduPilot SITL's 5760, and discovers it at once. MAVSDK 3.x takes
the same address (examples/pytest/test_mavsdk3.py).

    pytest examples/pytest/test_mavsdk4.py
"""
import time

import pytest

mavsdk = pytest.importorskip("mavsdk")
if not hasattr(mavsdk, "Mavsdk"):         # 3.x: the gRPC API (test_mavsdk3.py)
    pytest.skip("this is the MAVSDK 4.x example; 3.x is installed here", allow_module_level=True)

from mavsdk import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.plugins.action import Action  # noqa: E402
from mavsdk.plugins.offboard import Offboard, PositionNedYaw  # noqa: E402
from mavsdk.plugins.telemetry import Telemetry  # noqa: E402


def until(cond, timeout: float, what: str) -> None:
    """MAVSDK 4.x's telemetry getters answer at once (the newest value, or raise before the
    first): poll them with a wall-clock deadline."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if cond():
                return
        except Exception:  # noqa: BLE001 - no value yet
            pass
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def fly(address: str) -> None:
    """The script under test: arm, take off to 5 m, Offboard to (10 N, 5 E, 5 up), land."""
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    sdk.add_any_connection(address)
    system = sdk.first_autopilot(10.0)
    assert system is not None, "no autopilot discovered"
    tel, action, offboard = Telemetry(system), Action(system), Offboard(system)
    until(lambda: tel.health().is_armable and tel.health().is_home_position_ok, 10, "armable")
    action.arm()
    action.set_takeoff_altitude(5.0)
    action.takeoff()
    until(lambda: tel.position_velocity_ned().position.down_m < -4.5, 30, "5 m")
    offboard.set_position_ned(PositionNedYaw(10.0, 5.0, -5.0, 0.0))
    offboard.start()
    until(lambda: abs(tel.position_velocity_ned().position.north_m - 10.0) < 0.5, 30, "the offboard goal")
    offboard.stop()
    action.land()
    until(lambda: not tel.armed(), 60, "landed and disarmed")


@pytest.mark.towerlink(drones=1, speedup=10)
def test_mavsdk4_offboard_flight(towerlink_sitl):
    fly(towerlink_sitl.mavsdk_address(0))
    v = towerlink_sitl.vehicle(0)
    assert v.landed and not v.armed
    assert v.distance_to(10.0, 5.0) < 1.0
