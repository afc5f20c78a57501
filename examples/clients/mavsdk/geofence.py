#!/usr/bin/env python3
"""Upload an inclusion polygon around home as the geofence, then read it back (after
MAVSDK-Python's examples/geofence.py).

Usage: geofence.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System
from mavsdk.geofence import FenceType, GeofenceData, Point, Polygon

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

    print("Waiting for drone to have a global position estimate...")
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position estimate OK")
            break

    print("Fetching home location coordinates...")
    async for terrain_info in drone.telemetry.home():
        latitude = terrain_info.latitude_deg
        longitude = terrain_info.longitude_deg
        break

    await asyncio.sleep(1)

    p1 = Point(latitude - 0.0001, longitude - 0.0001)
    p2 = Point(latitude + 0.0001, longitude - 0.0001)
    p3 = Point(latitude + 0.0001, longitude + 0.0001)
    p4 = Point(latitude - 0.0001, longitude + 0.0001)
    polygon = Polygon([p1, p2, p3, p4], FenceType.INCLUSION)
    geofence_data = GeofenceData(polygons=[polygon], circles=[])

    print("Uploading geofence...")
    await drone.geofence.upload_geofence(geofence_data)
    print("Geofence uploaded!")

    got = await drone.geofence.download_geofence()
    print(f"-- downloaded {len(got.polygons)} polygon(s) with {sum(len(p.points) for p in got.polygons)} points")


if __name__ == "__main__":
    asyncio.run(run())
