#!/usr/bin/env python3
"""One of ArduPilot's telemetry stream groups: stop every stream, request only GROUP at 4 Hz
(REQUEST_DATA_STREAM, as MAVProxy and Mission Planner do), and list the messages that arrive;
each message ArduCopter sends in that group must come (GCS_MAVLink_Copter.cpp STREAM_*_msgs),
and none of the other groups'.

Usage: telemetry_group.py DEVICE GROUP MESSAGE...
"""
import sys
import time

from helpers import Vehicle, mavlink

GROUPS = {"RAW_SENSORS": 1, "EXTENDED_STATUS": 2, "RC_CHANNELS": 3, "POSITION": 6,
          "EXTRA1": 10, "EXTRA2": 11, "EXTRA3": 12}

group, wanted = sys.argv[2], sys.argv[3:]
v = Vehicle()
m = v.mav
for _ in range(3):
    m.mav.request_data_stream_send(m.target_system, m.target_component, mavlink.MAV_DATA_STREAM_ALL, 0, 0)
time.sleep(1)
m.mav.request_data_stream_send(m.target_system, m.target_component, GROUPS[group], 4, 1)
time.sleep(1)
while m.recv_match(blocking=False) is not None:
    pass                # what was sent before the new rates
seen = {}
end = time.time() + 4
while time.time() < end:
    msg = v.recv(wanted + ["SYS_STATUS", "GLOBAL_POSITION_INT", "ATTITUDE", "VFR_HUD"], timeout=0.5)
    if msg is not None and msg.get_srcSystem() == m.target_system:
        seen[msg.get_type()] = seen.get(msg.get_type(), 0) + 1
for name in sorted(seen):
    print(f"{name}: {seen[name] / 4:.1f} Hz")
missing = [w for w in wanted if w not in seen]
# one message of each other group: with every stream stopped but this one, none of them comes
others = {"EXTENDED_STATUS": "SYS_STATUS", "POSITION": "GLOBAL_POSITION_INT", "EXTRA1": "ATTITUDE",
          "EXTRA2": "VFR_HUD"}
leaked = [name for g, name in others.items() if g != group and name in seen]
print(f"missing: {' '.join(missing) or 'none'}")
print(f"from groups not asked for: {' '.join(leaked) or 'none'}")
sys.exit(1 if missing or leaked else 0)
