"""MAVProxy, as a user runs it, gets the messages behind its EKF, vibration, servo, RC and
navigation displays: it asks for every stream (REQUEST_DATA_STREAM ALL at 4 Hz) and its
`status` command shows the last message of each type."""
from __future__ import annotations

import re

import pytest

from support import wait_until
from test_sitl_support import MavProxy, Sitl


@pytest.mark.timeout(120)
def test_mavproxy_shows_ekf_vibration_servo_rc_and_nav(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    mp = MavProxy(processes, tmp_path, sitl.tcp[0])
    try:
        wait_until(lambda: mp.saw("online system 1"), 30, "MAVProxy online")
        shown = ("EKF_STATUS_REPORT", "VIBRATION", "SERVO_OUTPUT_RAW", "RC_CHANNELS", "NAV_CONTROLLER_OUTPUT",
                 "RAW_IMU", "AHRS2")

        def all_shown() -> bool:
            for name in shown:
                mp.send(f"status {name}")
            return all(mp.saw(f" {name} {{") for name in shown)
        wait_until(all_shown, 30, "MAVProxy's status of " + ", ".join(shown))
        ekf = [line for line in mp.lines if " EKF_STATUS_REPORT {" in line][-1]
        assert re.search(r"flags : 831\b", ekf), ekf
        rc = [line for line in mp.lines if " RC_CHANNELS {" in line][-1]
        assert "chancount : 16" in rc and "chan1_raw : 1500" in rc, rc
        mp.send("exit")
    finally:
        processes.stop(mp.proc)
