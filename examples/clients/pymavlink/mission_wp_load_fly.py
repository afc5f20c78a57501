#!/usr/bin/env python3
"""Load a QGC WPL file with pymavlink's mavwp, upload it with the MISSION_COUNT /
MISSION_REQUEST_INT handshake, take off in GUIDED, switch to AUTO, follow MISSION_ITEM_REACHED
to the end (the mission ends with LAND) (pymavlink's mavwp, as ArduPilot's dev docs show).

Usage: mission_wp_load_fly.py [DEVICE]
"""
import os
import sys

from pymavlink import mavutil, mavwp

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
master.mav.request_data_stream_send(master.target_system, master.target_component,
                                    mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)

wp = mavwp.MAVWPLoader()
wp.load(os.path.join(os.path.dirname(os.path.abspath(__file__)), "square.waypoints"))
print(f"Loaded {wp.count()} waypoints")
master.waypoint_clear_all_send()
print("clear:", master.recv_match(type="MISSION_ACK", blocking=True, timeout=5))
master.waypoint_count_send(wp.count())
while True:
    msg = master.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True, timeout=10)
    if msg is None:
        sys.exit("upload timed out")
    if msg.get_type() == "MISSION_ACK":
        print(f"MISSION_ACK {msg.type}")
        break
    item = wp.wp(msg.seq)
    item.target_system, item.target_component = master.target_system, master.target_component
    master.mav.send(item)
    print(f"Sent waypoint {msg.seq}")

master.set_mode(master.mode_mapping()["GUIDED"])
master.arducopter_arm()
master.motors_armed_wait()
master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 5)
while master.recv_match(type="GLOBAL_POSITION_INT", blocking=True).relative_alt < 4500:
    pass
master.set_mode(master.mode_mapping()["AUTO"])
last = wp.count() - 1
while True:
    msg = master.recv_match(type=["MISSION_ITEM_REACHED", "HEARTBEAT"], blocking=True)
    if msg.get_type() == "MISSION_ITEM_REACHED":
        print(f"Reached waypoint {msg.seq}")
    elif msg.get_srcComponent() == 1 and not msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED:
        print("Disarmed at the end of the mission")
        break
