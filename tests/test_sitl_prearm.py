"""Pre-arm before a position estimate, on the real `towerlink sitl` (issue 8): every other test
waits for "armable" first, so here the arm goes out at once. The world runs at 0.2x so the
estimator's first second of sim time lasts 5 wall seconds: the arm reaches it before then."""
from __future__ import annotations

import pytest

from test_sitl_support import Sitl, command, connect, mav, recv, wait_armable

pytestmark = pytest.mark.timeout(90)


def test_arm_refused_before_position_estimate_with_ardupilot_text(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=0.2)
    m = connect(sitl.udp[0])
    st = recv(m, "SYS_STATUS", 10)
    assert not st.onboard_control_sensors_health & mav.MAV_SYS_STATUS_SENSOR_GPS   # no estimate yet
    m.mav.command_long_send(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    texts, ack = [], None
    while ack is None:
        msg = recv(m, ["COMMAND_ACK", "STATUSTEXT"], 10)
        if msg.get_type() == "STATUSTEXT":
            texts.append((msg.severity, msg.text))
        elif msg.command == 400:
            ack = msg
    assert ack.result == mav.MAV_RESULT_FAILED
    assert (mav.MAV_SEVERITY_CRITICAL, "PreArm: Need Position Estimate") in texts
    assert not recv(m, "HEARTBEAT", 10).base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED
    # once the estimate is there, the same command arms
    wait_armable(m, timeout=40)
    assert command(m, 400, 1, timeout=10) == mav.MAV_RESULT_ACCEPTED
    assert command(m, 400, 0, timeout=10) == mav.MAV_RESULT_ACCEPTED
