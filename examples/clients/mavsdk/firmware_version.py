#!/usr/bin/env python3
"""Print the autopilot's firmware version (after MAVSDK-Python's examples/firmware_version.py).

Usage: firmware_version.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051


async def run():
    drone = System(port=GRPC_PORT)
    await drone.connect(system_address=ADDRESS)

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    info = await drone.info.get_version()
    print(info)
    print(f"-- flight software {info.flight_sw_major}.{info.flight_sw_minor}.{info.flight_sw_patch}")


if __name__ == "__main__":
    asyncio.run(run())
