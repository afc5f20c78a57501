"""MAVProxy, driven through stdin as a user would type: connects over TCP 5760-style,
fetches every parameter (count matches the vehicle's), shows EKF, vibration, servo, RC and
navigation data, switches to GUIDED, arms."""
from __future__ import annotations

import re

import pytest

from support import wait_until
from test_sitl_support import MavProxy, Sitl, connect, recv



@pytest.mark.timeout(120)
def test_mavproxy_params_mode_arm(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    m.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
    count = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "SYSID_THISMAV").param_count
    m.close()
    mp = MavProxy(processes, tmp_path, sitl.tcp[0])
    proxy, lines, saw, send = mp.proc, mp.lines, mp.saw, mp.send

    try:
        wait_until(lambda: saw("Detected vehicle 1:1"), 30, "MAVProxy to see the vehicle")
        wait_until(lambda: saw("online system 1"), 30, "online")
        send("param fetch")
        wait_until(lambda: saw("Received") and saw("parameters"), 60, "parameters: " + "".join(lines[-5:]))
        got = [l for l in lines if "Received" in l and "parameters" in l][-1]
        assert int(got.split("Received")[1].split()[0]) == count, got
        # its EKF, vibration, servo, RC and navigation displays get data: `status` shows the last
        # message of each type (it asked for every stream at 4 Hz when it connected)
        shown = ("EKF_STATUS_REPORT", "VIBRATION", "SERVO_OUTPUT_RAW", "RC_CHANNELS", "NAV_CONTROLLER_OUTPUT",
                 "RAW_IMU", "AHRS2")

        def all_shown() -> bool:
            for name in shown:
                send(f"status {name}")
            return all(saw(f" {name} {{") for name in shown)
        wait_until(all_shown, 30, "MAVProxy's status of " + ", ".join(shown))
        ekf = [line for line in lines if " EKF_STATUS_REPORT {" in line][-1]
        assert re.search(r"flags : 831\b", ekf), ekf
        rc = [line for line in lines if " RC_CHANNELS {" in line][-1]
        assert "chancount : 8" in rc and "chan1_raw : 1500" in rc and "chan3_raw : 1000" in rc, rc
        send("mode GUIDED")
        wait_until(lambda: saw("Mode GUIDED"), 20, "GUIDED")
        send("arm throttle")
        wait_until(lambda: saw("ARMED") and not saw("DISARMED"), 20, "ARMED")
        assert saw("COMPONENT_ARM_DISARM: ACCEPTED")
        send("disarm")
        wait_until(lambda: saw("DISARMED"), 20, "DISARMED")
        send("exit")
    finally:
        processes.stop(proxy)
    assert not saw("fence breach")
