#!/usr/bin/env python3
"""Print the first value of each telemetry stream a user starts with (after MAVSDK-Python's
examples/telemetry.py: position, battery, GPS info, in air, attitude, flight mode, health).

Usage: telemetry.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051


async def first(name, stream):
    async for value in stream:
        print(f"{name}: {value}")
        return


async def run():
    drone = System(port=GRPC_PORT)
    await drone.connect(system_address=ADDRESS)

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    t = drone.telemetry
    await asyncio.wait_for(asyncio.gather(
        first("position", t.position()), first("battery", t.battery()), first("gps_info", t.gps_info()),
        first("in_air", t.in_air()), first("attitude_euler", t.attitude_euler()),
        first("flight_mode", t.flight_mode()), first("health", t.health()), first("home", t.home()),
        first("velocity_ned", t.velocity_ned()),
        first("rc_status", t.rc_status()), first("landed_state", t.landed_state()),
    ), 30)
    print("-- every stream answered")


if __name__ == "__main__":
    asyncio.run(run())
