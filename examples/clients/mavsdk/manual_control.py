#!/usr/bin/env python3
"""Manual control inputs (after MAVSDK-Python's examples/manual_control.py): take off, start
position control (ArduCopter's POSHOLD), then stick inputs; a sequence instead of the example's
random one, ending with full throttle to climb, then land.

Usage: manual_control.py [ADDRESS [GRPC_PORT]]
"""
import asyncio
import sys

from mavsdk import System

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
GRPC_PORT = int(sys.argv[2]) if len(sys.argv) > 2 else 50051

manual_inputs = [
    [0, 0, 0.5, 0],  # no movement
    [-1, 0, 0.5, 0],  # minimum roll
    [1, 0, 0.5, 0],  # maximum roll
    [0, -1, 0.5, 0],  # minimum pitch
    [0, 1, 0.5, 0],  # maximum pitch
    [0, 0, 0.5, -1],  # minimum yaw
    [0, 0, 0.5, 1],  # maximum yaw
    [0, 0, 1, 0],  # max throttle
]


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
            print("-- Global position state is good enough for flying.")
            break

    await drone.manual_control.set_manual_control_input(0.0, 0.0, 0.5, 0.0)

    print("-- Arming")
    await drone.action.arm()

    print("-- Taking off")
    await drone.action.set_takeoff_altitude(5.0)
    await drone.action.takeoff()
    await asyncio.sleep(8)

    await drone.manual_control.set_manual_control_input(0.0, 0.0, 0.5, 0.0)

    print("-- Starting manual control")
    await drone.manual_control.start_position_control()

    for roll, pitch, throttle, yaw in manual_inputs:
        print(f"-- sticks roll {roll} pitch {pitch} throttle {throttle} yaw {yaw}")
        for _ in range(20):
            await drone.manual_control.set_manual_control_input(float(pitch), float(roll), float(throttle), float(yaw))
            await asyncio.sleep(0.1)

    async for position in drone.telemetry.position():
        print(f"-- relative altitude after full throttle: {position.relative_altitude_m:.1f} m")
        break

    print("-- Landing")
    await drone.action.land()


if __name__ == "__main__":
    asyncio.run(run())
