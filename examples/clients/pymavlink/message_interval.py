#!/usr/bin/env python3
"""Set ATTITUDE to 20 Hz with MAV_CMD_SET_MESSAGE_INTERVAL, read it back with
GET_MESSAGE_INTERVAL, measure it from time_boot_ms, then stop it (-1) (the ArduPilot dev
docs' "Requesting Data From The Autopilot" recipe).

Usage: message_interval.py [DEVICE]
"""
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
ATT = mavutil.mavlink.MAVLINK_MSG_ID_ATTITUDE


def command(cmd, *p):
    p = list(p) + [0] * (7 - len(p))
    master.mav.command_long_send(master.target_system, master.target_component, cmd, 0, *p)
    ack = master.recv_match(type="COMMAND_ACK", condition=f"COMMAND_ACK.command=={cmd}", blocking=True, timeout=5)
    print(f"COMMAND_ACK {cmd}: {ack.result if ack else None}")


command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATT, 50000)
command(mavutil.mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, ATT)
mi = master.recv_match(type="MESSAGE_INTERVAL", blocking=True, timeout=5)
print(f"MESSAGE_INTERVAL: {mi.interval_us if mi else None} us")
time.sleep(1)
stamps = []
while len(stamps) < 60:
    msg = master.recv_match(type="ATTITUDE", blocking=True, timeout=5)
    stamps.append(msg.time_boot_ms)
rate = (len(stamps) - 1) / ((stamps[-1] - stamps[0]) / 1000.0)
print(f"ATTITUDE rate {rate:.1f} Hz")
command(mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, ATT, -1)
time.sleep(1)
master.recv_match(type="ATTITUDE", blocking=False)
while master.recv_match(type="ATTITUDE", blocking=False):
    pass
late = master.recv_match(type="ATTITUDE", blocking=True, timeout=3)
print("ATTITUDE stopped" if late is None else "ATTITUDE still coming")
