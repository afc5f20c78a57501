#!/usr/bin/env python3
"""GUIDED, arm, take off to 10 m, LAND, wait for the disarm (after the pymavlink snippets in
ArduPilot's dev docs, "Copter Commands in Guided Mode", and pymavlink's mavutil helpers).

Usage: arm_takeoff_land.py [DEVICE]
"""
import sys

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
print("Heartbeat from system (system %u component %u)" % (master.target_system, master.target_component))
master.mav.request_data_stream_send(master.target_system, master.target_component,
                                    mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)

master.set_mode(master.mode_mapping()["GUIDED"])
ack = master.recv_match(type="COMMAND_ACK", blocking=True, timeout=5)
print("mode change:", ack)

master.arducopter_arm()
master.motors_armed_wait()
print("Armed")

master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 10)
while True:
    msg = master.recv_match(type="GLOBAL_POSITION_INT", blocking=True)
    alt = msg.relative_alt / 1000.0
    if alt > 9.5:
        print(f"Reached {alt:.1f} m")
        break

master.set_mode(master.mode_mapping()["LAND"])
master.motors_disarmed_wait()
print("Landed and disarmed")
