#!/usr/bin/env python3
"""takeoff_and_land with MAVSDK 4.x's native API (what `pip install mavsdk` gives now): discover
the autopilot, wait until armable, arm, take off to 5 m, land, wait for the disarm.

Usage: takeoff_and_land_v4.py [ADDRESS]   (default udpin://0.0.0.0:14540)
"""
import sys
import time

from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.action import Action
from mavsdk.plugins.telemetry import Telemetry

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"


def wait_for(cond, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if cond():
                return
        except Exception:  # noqa: BLE001 - no value yet
            pass
        time.sleep(0.05)
    raise SystemExit(f"timed out waiting for {what}")


sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
sdk.add_any_connection(ADDRESS)
system = sdk.first_autopilot(20.0)
if system is None:
    raise SystemExit("no autopilot")
print("-- Connected to drone!")
telemetry, action = Telemetry(system), Action(system)
wait_for(lambda: telemetry.health().is_armable and telemetry.health().is_home_position_ok, 60, "armable")
print("-- Arming")
action.arm()
action.set_takeoff_altitude(5.0)
print("-- Taking off")
action.takeoff()
wait_for(lambda: telemetry.position().relative_altitude_m > 4.5, 60, "5 m")
print(f"-- At {telemetry.position().relative_altitude_m:.1f} m")
print("-- Landing")
action.land()
wait_for(lambda: not telemetry.armed(), 90, "landed and disarmed")
print("-- Landed and disarmed")
