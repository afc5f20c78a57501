#!/usr/bin/env python3
"""FS_GCS_ENABLE 1: take off, then stop sending GCS heartbeats; after FS_GCS_TIMEOUT ArduCopter
says "GCS Failsafe" and flies RTL home, where it lands (autotest's GCSFailsafe)."""
from helpers import run


def test(v):
    v.set_parameter("FS_GCS_ENABLE", 1)
    v.takeoff(10)
    v.fly_guided_to_local(20, 0, 10)
    v.wait_until("GLOBAL_POSITION_INT", lambda p: v.distance_from_home() > 18, 60, "20 m out")
    v.progress("stopping GCS heartbeats")
    v.send_heartbeats = False
    v.wait_mode("RTL", timeout=30)
    v.wait_statustext("(?i)gcs failsafe", regex=True, timeout=10)
    v.wait_disarmed(timeout=120)


run(test)
