#!/usr/bin/env python3
"""Take off in GUIDED, switch to ALT_HOLD and fly it with RC_CHANNELS_OVERRIDE: throttle up to
climb, pitch forward to move, then release the override and LAND (the ArduSub/ArduCopter
"RC Input and Output" pymavlink recipe).

Usage: rc_override.py [DEVICE]
"""
import sys
import time

from pymavlink import mavutil

device = sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"
master = mavutil.mavlink_connection(device)
master.wait_heartbeat()
master.mav.request_data_stream_send(master.target_system, master.target_component,
                                    mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)


def set_rc_channel_pwm(channels):
    """channels: {number: pwm}; 65535 leaves a channel alone, 0 releases it."""
    rc = [65535] * 18
    for ch, pwm in channels.items():
        rc[ch - 1] = pwm
    master.mav.rc_channels_override_send(master.target_system, master.target_component, *rc)


def hold(channels, seconds):
    end = time.time() + seconds
    while time.time() < end:
        set_rc_channel_pwm(channels)
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
hold({3: 1500}, 1)
master.set_mode(master.mode_mapping()["ALT_HOLD"])
hold({3: 1500}, 2)
print(f"ALT_HOLD at {altitude():.1f} m, throttle up")
hold({3: 1800}, 5)
print(f"after throttle up: {altitude():.1f} m")
hold({3: 1500, 2: 1300}, 4)
print("after pitch forward")
hold({1: 0, 2: 0, 3: 0}, 0.5)
master.set_mode(master.mode_mapping()["LAND"])
master.motors_disarmed_wait()
print("Landed and disarmed")
