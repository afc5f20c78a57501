#!/usr/bin/env python3
"""List the autopilot's root folder and @SYS over MAVFTP (after MAVSDK-Python's
examples/ftp_list_dir.py).

Usage: ftp_list_dir.py [ADDRESS [GRPC_PORT]]
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

    for remote in ("/", "@SYS"):
        print(f"Directory list of {remote}")
        result = await drone.ftp.list_directory(remote)
        for d in result.dirs:
            print(f"  dir  {d}")
        for f in result.files:
            print(f"  file {f}")
        print(f"-- listed {len(result.dirs) + len(result.files)} entries in {remote}")


if __name__ == "__main__":
    asyncio.run(run())
