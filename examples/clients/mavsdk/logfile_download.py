#!/usr/bin/env python3
"""Fly a short hop so the autopilot writes a log, then list the logs and download each one
(after MAVSDK-Python's examples/logfile_download.py; the hop is there because a fresh
ArduPilot SITL has no log until its first arming).

Usage: logfile_download.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import os
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

    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            break
    await drone.action.arm()
    await drone.action.set_takeoff_altitude(3.0)
    await drone.action.takeoff()
    await asyncio.sleep(6)
    await drone.action.land()
    async for armed in drone.telemetry.armed():
        if not armed:
            print("-- Landed and disarmed")
            break

    entries = await get_entries(drone)
    for entry in entries:
        await download_log(drone, entry)


async def download_log(drone, entry):
    date_without_colon = entry.date.replace(":", "-")
    filename = f"./log-{entry.id}-{date_without_colon}.bin"
    print(f"Downloading: log {entry.id} from {entry.date} to {filename}")
    previous_progress = -1
    async for progress in drone.log_files.download_log_file(entry, filename):
        new_progress = round(progress.progress * 100)
        if new_progress != previous_progress:
            sys.stdout.write(f"\r{new_progress} %")
            sys.stdout.flush()
            previous_progress = new_progress
    print()
    print(f"Downloaded {filename}: {os.path.getsize(filename)} bytes")


async def get_entries(drone):
    entries = await drone.log_files.get_entries()
    for entry in entries:
        print(f"Log {entry.id} from {entry.date}")
    return entries


if __name__ == "__main__":
    asyncio.run(run())
