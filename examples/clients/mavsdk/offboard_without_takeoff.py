#!/usr/bin/env python3
"""MAVSDK-Python's examples/offboard_position_ned.py flow unchanged: arm, set a setpoint, start
offboard on the ground and send position setpoints. ArduCopter does not take off from GUIDED
position targets (a landed copter stays on the ground until a takeoff command), so against
ArduPilot SITL the copter stays down and disarms itself.

Usage: offboard_without_takeoff.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System
from mavsdk.offboard import OffboardError, PositionNedYaw

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

    print("-- Setting initial setpoint")
    await drone.offboard.set_position_ned(PositionNedYaw(0.0, 0.0, 0.0, 0.0))

    print("-- Starting offboard")
    try:
        await drone.offboard.start()
    except OffboardError as error:
        print(f"Starting offboard mode failed with error code: {error._result.result}")
        print("-- Disarming")
        await drone.action.disarm()
        return

    print("-- Go 0m North, 0m East, -5m Down within local coordinate system")
    await drone.offboard.set_position_ned(PositionNedYaw(0.0, 0.0, -5.0, 0.0))
    await asyncio.sleep(10)

    print("-- Go 5m North, 0m East, -5m Down within local coordinate system, turn to face East")
    await drone.offboard.set_position_ned(PositionNedYaw(5.0, 0.0, -5.0, 90.0))
    await asyncio.sleep(10)

    print("-- Stopping offboard")
    try:
        await drone.offboard.stop()
    except OffboardError as error:
        print(f"Stopping offboard mode failed with error code: {error._result.result}")


if __name__ == "__main__":
    asyncio.run(run())
