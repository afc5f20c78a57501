#!/usr/bin/env python3
"""Request every stream at 4 Hz, then count what arrives for 5 s (after pymavlink's
examples/apmsetrate.py, with --showmessages summarised as counts).

Usage: apmsetrate.py [DEVICE]
"""
import collections
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
rate = 4
master = mavutil.mavlink_connection(device)
print("Waiting for APM heartbeat")
master.wait_heartbeat()
print("Heartbeat from APM (system %u component %u)" % (master.target_system, master.target_component))

print("Sending all stream request for rate %u" % rate)
for i in range(0, 3):
    master.mav.request_data_stream_send(master.target_system, master.target_component,
                                        mavutil.mavlink.MAV_DATA_STREAM_ALL, rate, 1)
time.sleep(2)          # let the new rates settle
while master.recv_match(blocking=False) is not None:
    pass                # what came before the new rates
counts = collections.Counter()
start = time.time()
while time.time() - start < 5:
    msg = master.recv_match(blocking=True, timeout=1)
    if msg is not None and msg.get_srcSystem() == master.target_system:
        counts[msg.get_type()] += 1
for name, n in sorted(counts.items()):
    print(f"{name:24s} {n / 5:.1f} Hz")
