#!/usr/bin/env python3
"""Take off, fly to a point 20 m above home with goto_location, land there (after MAVSDK-Python's
examples/goto.py; the goal is moved next to ArduPilot SITL's home, and the endless wait at the
end becomes a wait for arrival).

Usage: goto.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import math
import sys

from mavsdk import System

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051
GOAL = (-35.362761, 149.165830)       # about 55 m north, 55 m east of SITL's home


async def run():
    drone = System(port=GRPC_PORT)
    await drone.connect(system_address=ADDRESS)

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    print("Waiting for drone to have a global position estimate...")
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position state is good enough for flying.")
            break

    print("Fetching amsl altitude at home location....")
    async for terrain_info in drone.telemetry.home():
        absolute_altitude = terrain_info.absolute_altitude_m
        break

    print("-- Arming")
    await drone.action.arm()

    print("-- Taking off")
    await drone.action.takeoff()

    await asyncio.sleep(1)
    flying_alt = absolute_altitude + 20.0
    await drone.action.goto_location(GOAL[0], GOAL[1], flying_alt, 0)

    async for position in drone.telemetry.position():
        dn = (position.latitude_deg - GOAL[0]) * 111319.5
        de = (position.longitude_deg - GOAL[1]) * 111319.5 * math.cos(math.radians(GOAL[0]))
        if math.hypot(dn, de) < 2.0 and abs(position.absolute_altitude_m - flying_alt) < 1.0:
            print("-- Arrived")
            break

    print("-- Landing")
    await drone.action.land()


if __name__ == "__main__":
    asyncio.run(run())
