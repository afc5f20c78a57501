#!/usr/bin/env python3
"""MAVSDK-Python's examples/mission.py flow: upload three waypoints with the Mission plugin,
arm, start the mission. Against ArduPilot the upload already fails: the plugin's items carry
NaN params that ArduPilot's mission checks refuse.

Usage: mission.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System
from mavsdk.mission import MissionItem, MissionPlan

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051


def item(lat, lon):
    return MissionItem(lat, lon, 25, 10, True, float("nan"), float("nan"), MissionItem.CameraAction.NONE,
                       float("nan"), float("nan"), float("nan"), float("nan"), float("nan"),
                       MissionItem.VehicleAction.NONE)


async def run():
    drone = System(port=GRPC_PORT)
    await drone.connect(system_address=ADDRESS)

    status_text_task = asyncio.ensure_future(print_status_text(drone))

    print("Waiting for drone to connect...")
    async for state in drone.core.connection_state():
        if state.is_connected:
            print("-- Connected to drone!")
            break

    mission_items = [item(-35.362761, 149.165230), item(-35.362761, 149.165830), item(-35.363261, 149.165830)]
    mission_plan = MissionPlan(mission_items)

    await drone.mission.set_return_to_launch_after_mission(True)

    print("-- Uploading mission")
    await drone.mission.upload_mission(mission_plan)

    print("Waiting for drone to have a global position estimate...")
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            print("-- Global position estimate OK")
            break

    print("-- Arming")
    await drone.action.arm()

    print("-- Starting mission")
    try:
        await drone.mission.start_mission()
    finally:
        await asyncio.sleep(2)
        status_text_task.cancel()


async def print_status_text(drone):
    try:
        async for status_text in drone.telemetry.status_text():
            print(f"Status: {status_text.type}: {status_text.text}")
    except asyncio.CancelledError:
        return


if __name__ == "__main__":
    asyncio.run(run())
