#!/usr/bin/env python3
"""Wait for the heartbeat, ask for AUTOPILOT_VERSION and the banner, print them (after
pymavlink's examples/status_msg.py).

Usage: banner_version.py [DEVICE]   (default tcp:127.0.0.1:5760, ArduPilot SITL's)
"""
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
hb = master.wait_heartbeat(timeout=30)
print(f"Heartbeat from system {master.target_system} component {master.target_component}: "
      f"type {hb.type} autopilot {hb.autopilot} mavlink{hb.get_header().mlen and 2}")

master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                             mavutil.mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_DO_SEND_BANNER, 0, 0, 0, 0, 0, 0, 0, 0)
version = None
end = time.time() + 10
while time.time() < end:
    msg = master.recv_match(type=["AUTOPILOT_VERSION", "STATUSTEXT"], blocking=True, timeout=1)
    if msg is None:
        continue
    if msg.get_type() == "STATUSTEXT":
        print(f"STATUSTEXT: {msg.text}")
    elif version is None:
        version = msg
        v = msg.flight_sw_version
        print(f"Firmware Version: {v >> 24 & 0xFF}.{v >> 16 & 0xFF}.{v >> 8 & 0xFF} type {v & 0xFF}")
        caps = [name for bit, name in ((mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2, "MAVLINK2"),
                                       (mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_FTP, "FTP"),
                                       (mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT, "MISSION_INT"),
                                       (mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT, "COMMAND_INT"),
                                       (mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE, "MISSION_FENCE"),
                                       (mavutil.mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY, "MISSION_RALLY"))
                if msg.capabilities & bit]
        print("Capabilities: " + " ".join(caps))
        print(f"Git Hash: {bytes(msg.flight_custom_version).hex()}")
if version is None:
    sys.exit("no AUTOPILOT_VERSION")
