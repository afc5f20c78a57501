#!/usr/bin/env python3
"""Upload a mission with mission_raw (home, TAKEOFF 10 m, three waypoints, RTL) as ArduPilot
users do, arm, take off, start it, print progress until it is done and the copter is back on
the ground (after MAVSDK-Python's examples/mission_raw.py and mission.py). start_mission is a
mode change to AUTO, and ArduCopter armed on the ground with the throttle at zero does not
start an AUTO takeoff (see autotest/auto_takeoff_throttle_zero.py), so ArduPilot users take
off first.

Usage: mission_raw.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System
from mavsdk.mission_raw import MissionItem

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051
REL = 3       # MAV_FRAME_GLOBAL_RELATIVE_ALT


def e7(deg):
    return int(round(deg * 1e7))


async def run():
    drone = System(port=GRPC_PORT)
    await drone.connect(system_address=ADDRESS)

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position estimate OK")
            break

    async for home in drone.telemetry.home():
        lat, lon = home.latitude_deg, home.longitude_deg
        break

    items = [
        MissionItem(0, 0, 16, 1, 1, 0, 0, 0, 0, e7(lat), e7(lon), 0, 0),
        MissionItem(1, REL, 22, 0, 1, 0, 0, 0, 0, 0, 0, 10, 0),
        MissionItem(2, REL, 16, 0, 1, 0, 0, 0, 0, e7(lat + 0.0002), e7(lon), 10, 0),
        MissionItem(3, REL, 16, 0, 1, 0, 0, 0, 0, e7(lat + 0.0002), e7(lon + 0.0002), 10, 0),
        MissionItem(4, REL, 16, 0, 1, 0, 0, 0, 0, e7(lat), e7(lon + 0.0002), 10, 0),
        MissionItem(5, REL, 20, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0),
    ]
    print("-- Uploading mission")
    await drone.mission_raw.upload_mission(items)

    print("-- Arming")
    await drone.action.arm()
    print("-- Taking off")
    await drone.action.set_takeoff_altitude(10.0)
    await drone.action.takeoff()
    await asyncio.sleep(6)

    print("-- Starting mission")
    await drone.mission_raw.start_mission()

    async for progress in drone.mission_raw.mission_progress():
        print(f"Mission progress: {progress.current}/{progress.total}")
        if progress.current == progress.total - 1:
            break

    async for armed in drone.telemetry.armed():
        if not armed:
            print("-- Disarmed, mission done")
            break


if __name__ == "__main__":
    asyncio.run(run())
