#!/usr/bin/env python3
"""SIM_GPS1_ENABLE 0 while hovering in GUIDED: GPS_RAW_INT loses its fix, the EKF loses its
position and ArduCopter's EKF failsafe (FS_EKF_ACTION 1) lands (autotest's GPS-loss tests)."""
from helpers import run


def test(v):
    v.takeoff(10)
    v.set_parameter("SIM_GPS1_ENABLE", 0)
    gps = v.wait_until("GPS_RAW_INT", lambda g: g.fix_type < 3, 20, "GPS fix lost")
    v.progress(f"GPS_RAW_INT fix_type {gps.fix_type}")
    v.wait_mode("LAND", timeout=60)
    v.wait_disarmed(timeout=120)


run(test)
