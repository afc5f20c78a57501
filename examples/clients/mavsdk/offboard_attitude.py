#!/usr/bin/env python3
"""Offboard attitude control (after MAVSDK-Python's examples/offboard_attitude.py): take off
first as ArduCopter needs, then roll 30 degrees, pitch, level, land.

Usage: offboard_attitude.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System
from mavsdk.offboard import Attitude, OffboardError

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

    print("-- Arming")
    await drone.action.arm()
    print("-- Taking off")
    await drone.action.set_takeoff_altitude(10.0)
    await drone.action.takeoff()
    await asyncio.sleep(10)

    print("-- Setting initial setpoint")
    await drone.offboard.set_attitude(Attitude(0.0, 0.0, 0.0, 0.5))

    print("-- Starting offboard")
    try:
        await drone.offboard.start()
    except OffboardError as error:
        print(f"Starting offboard mode failed with error code: {error._result.result}")
        print("-- Disarming")
        await drone.action.disarm()
        return

    print("-- Roll 30 at 50% thrust")
    await drone.offboard.set_attitude(Attitude(30.0, 0.0, 0.0, 0.5))
    await asyncio.sleep(2)

    print("-- Roll -30 at 50% thrust")
    await drone.offboard.set_attitude(Attitude(-30.0, 0.0, 0.0, 0.5))
    await asyncio.sleep(2)

    print("-- Hover at 50% thrust")
    await drone.offboard.set_attitude(Attitude(0.0, 0.0, 0.0, 0.5))
    await asyncio.sleep(2)

    print("-- Stopping offboard")
    try:
        await drone.offboard.stop()
    except OffboardError as error:
        print(f"Stopping offboard mode failed with error code: {error._result.result}")

    print("-- Landing")
    await drone.action.land()


if __name__ == "__main__":
    asyncio.run(run())
