#!/usr/bin/env python3
"""Fetch and print every parameter (after MAVSDK-Python's examples/all_params.py).

Usage: all_params.py [ADDRESS [GRPC_PORT]]
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

    all_params = await drone.param.get_all_params()
    for param in all_params.int_params:
        print(f"{param.name}: {param.value}")
    for param in all_params.float_params:
        print(f"{param.name}: {param.value}")
    print(f"-- {len(all_params.int_params)} int and {len(all_params.float_params)} float parameters")


if __name__ == "__main__":
    asyncio.run(run())
