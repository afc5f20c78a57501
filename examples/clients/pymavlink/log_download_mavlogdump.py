#!/usr/bin/env python3
"""Fly a short hop, download the newest onboard log with LOG_REQUEST_LIST / LOG_REQUEST_DATA
(as MAVProxy's log module does), then read it with pymavlink's mavlogdump.py.

Usage: log_download_mavlogdump.py [DEVICE]
"""
import os
import subprocess
import sys
import tempfile

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
master.mav.request_data_stream_send(master.target_system, master.target_component,
                                    mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)
master.set_mode(master.mode_mapping()["GUIDED"])
master.arducopter_arm()
master.motors_armed_wait()
master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 3)
while master.recv_match(type="GLOBAL_POSITION_INT", blocking=True).relative_alt < 2500:
    pass
master.set_mode(master.mode_mapping()["LAND"])
master.motors_disarmed_wait()
print("Flew and landed")

master.mav.log_request_list_send(master.target_system, master.target_component, 0, 0xFFFF)
entries = {}
while True:
    e = master.recv_match(type="LOG_ENTRY", blocking=True, timeout=3)
    if e is None:
        break
    if e.num_logs:
        entries[e.id] = e.size
        print(f"Log {e.id}  numLogs {e.num_logs}  lastLog {e.last_log_num}  size {e.size}")
    if e.id == e.last_log_num:
        break
if not entries:
    sys.exit("no logs")
log_id = max(entries)
size = entries[log_id]
data = bytearray(size)
got = set()
while len(got) < (size + 89) // 90:
    missing = [o for o in range(0, size, 90) if o not in got]
    master.mav.log_request_data_send(master.target_system, master.target_component, log_id, missing[0],
                                     size - missing[0])
    while True:
        d = master.recv_match(type="LOG_DATA", blocking=True, timeout=2)
        if d is None or d.id != log_id:
            break
        data[d.ofs:d.ofs + d.count] = bytes(d.data[:d.count])
        got.add(d.ofs)
        if d.count < 90:
            break
master.mav.log_request_end_send(master.target_system, master.target_component)
path = os.path.join(tempfile.mkdtemp(), f"log{log_id}.bin")
with open(path, "wb") as f:
    f.write(data)
print(f"Finished downloading {path} ({size} bytes)")
dump = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
out = subprocess.run([sys.executable, dump, "--types", "ATT,MODE,ARM", path], capture_output=True, text=True,
                     timeout=120).stdout.splitlines()
for kind in ("ATT", "MODE", "ARM"):
    lines = [line for line in out if f" {kind} " in line or line.startswith(f"{kind} ")]
    print(f"mavlogdump: {len(lines)} {kind} messages")
