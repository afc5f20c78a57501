#!/usr/bin/env python3
"""Take off in GUIDED, switch to LOITER and fly it with MANUAL_CONTROL (a joystick's
message): full throttle to climb, pitch forward, then centre and LAND (the ArduSub/ArduCopter
pymavlink "Send MANUAL_CONTROL" recipe).

Usage: manual_control.py [DEVICE]
"""
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
master.mav.request_data_stream_send(master.target_system, master.target_component,
                                    mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)


def sticks(x, y, z, r, seconds):
    """x pitch, y roll, r yaw in -1000..1000; z throttle 0..1000 (500 centre)."""
    end = time.time() + seconds
    while time.time() < end:
        master.mav.manual_control_send(master.target_system, x, y, z, r, 0)
        time.sleep(0.1)


def altitude():
    return master.recv_match(type="GLOBAL_POSITION_INT", blocking=True).relative_alt / 1000.0


master.set_mode(master.mode_mapping()["GUIDED"])
master.arducopter_arm()
master.motors_armed_wait()
master.mav.command_long_send(master.target_system, master.target_component,
                             mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 10)
while altitude() < 9.5:
    pass
print("At 10 m")
sticks(0, 0, 500, 0, 1)
master.set_mode(master.mode_mapping()["LOITER"])
sticks(0, 0, 500, 0, 2)
sticks(0, 0, 1000, 0, 5)
print(f"after full throttle: {altitude():.1f} m")
sticks(800, 0, 500, 0, 4)
print("after pitch forward")
sticks(0, 0, 500, 0, 1)
master.set_mode(master.mode_mapping()["LAND"])
master.motors_disarmed_wait()
print("Landed and disarmed")
