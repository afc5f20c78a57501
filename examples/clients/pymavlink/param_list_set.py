#!/usr/bin/env python3
"""Fetch the whole parameter list, set one and read it back (the pymavlink parameter recipe
of ArduPilot's dev docs and MAVProxy's param fetch).

Usage: param_list_set.py [DEVICE]
"""
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()

master.mav.param_request_list_send(master.target_system, master.target_component)
params, count = {}, None
deadline = time.time() + 60
while time.time() < deadline and (count is None or len(params) < count):
    msg = master.recv_match(type="PARAM_VALUE", blocking=True, timeout=2)
    if msg is None:
        missing = [i for i in range(count or 0) if i not in {p[1] for p in params.values()}]
        for i in missing[:20]:          # ask again for what was lost, as MAVProxy does
            master.mav.param_request_read_send(master.target_system, master.target_component, b"", i)
        continue
    count = msg.param_count
    params[msg.param_id] = (msg.param_value, msg.param_index)
print(f"Received {len(params)} of {count} parameters")

master.mav.param_set_send(master.target_system, master.target_component, b"WPNAV_SPEED", 850.0,
                          mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
echo = master.recv_match(type="PARAM_VALUE", condition='PARAM_VALUE.param_id=="WPNAV_SPEED"', blocking=True, timeout=5)
print(f"set WPNAV_SPEED -> {echo.param_value if echo else None}")
master.mav.param_request_read_send(master.target_system, master.target_component, b"WPNAV_SPEED", -1)
back = master.recv_match(type="PARAM_VALUE", condition='PARAM_VALUE.param_id=="WPNAV_SPEED"', blocking=True, timeout=5)
print(f"read WPNAV_SPEED = {back.param_value if back else None}")
