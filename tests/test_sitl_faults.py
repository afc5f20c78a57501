"""A SITL fault over MAVLink on the real `towerlink sitl`: a GCS turns the GPS off with a PARAM_SET
of SIM_GPS1_ENABLE (ArduPilot 4.5's name) while the drone loiters. On the wire, as ArduCopter
would say it: GPS_RAW_INT has no fix, EKF_STATUS_REPORT loses the horizontal position flags,
then STATUSTEXT "EKF variance" and "EKF Failsafe: changed to LAND Mode", HEARTBEAT in LAND; the
failsafe's LAND holds its altitude 4 s (LAND_WITH_DELAY_MS), then descends."""
from __future__ import annotations

import pytest

from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, wait_armable

pytestmark = pytest.mark.timeout(120)

POS_FLAGS = mav.EKF_POS_HORIZ_ABS | mav.EKF_POS_HORIZ_REL


def test_gps_off_over_mavlink_takes_the_ekf_failsafe(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=5.0)
    m = connect(sitl.udp[0])
    wait_armable(m, timeout=40)
    assert command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT, 100000) == \
        mav.MAV_RESULT_ACCEPTED
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert command(m, 400, 1, timeout=10) == mav.MAV_RESULT_ACCEPTED
    # high enough that LOITER, sinking on the receiver's low throttle until the failsafe, is
    # still well up when LAND's pause is watched
    assert command(m, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 40.0) == mav.MAV_RESULT_ACCEPTED
    recv(m, "GLOBAL_POSITION_INT", 60, cond=lambda p: p.relative_alt > 39500)
    assert set_mode(m, "LOITER") == mav.MAV_RESULT_ACCEPTED
    assert recv(m, "EKF_STATUS_REPORT", 10).flags & POS_FLAGS == POS_FLAGS
    m.mav.param_set_send(1, 1, b"SIM_GPS1_ENABLE", 0, mav.MAV_PARAM_TYPE_INT8)
    recv(m, "PARAM_VALUE", 10, cond=lambda p: p.param_id == "SIM_GPS1_ENABLE" and p.param_value == 0)
    assert recv(m, "GPS_RAW_INT", 10, cond=lambda g: g.fix_type < mav.GPS_FIX_TYPE_3D_FIX).satellites_visible == 0
    # in the order the vehicle says it: the position flags go, then the failsafe's texts
    seen = []
    while "EKF Failsafe: changed to LAND Mode" not in seen:
        msg = recv(m, ["EKF_STATUS_REPORT", "STATUSTEXT"], 30)
        if msg.get_type() == "STATUSTEXT":
            seen.append(msg.text)
        elif not msg.flags & POS_FLAGS and "position lost" not in seen:
            seen.append("position lost")
    assert seen.index("position lost") < seen.index("EKF variance") < seen.index("EKF Failsafe: changed to LAND Mode")
    land = m.mode_mapping()["LAND"]
    recv(m, "HEARTBEAT", 10, cond=lambda h: h.get_srcSystem() == 1 and h.custom_mode == land)
    # (time_boot_ms is sim time) LAND stops LOITER's sink, holds for the rest of 4 s, descends
    start = recv(m, "GLOBAL_POSITION_INT", 10)
    stopped = recv(m, "GLOBAL_POSITION_INT", 30, cond=lambda p: p.time_boot_ms - start.time_boot_ms >= 2000)
    held = recv(m, "GLOBAL_POSITION_INT", 30, cond=lambda p: p.time_boot_ms - start.time_boot_ms >= 3500)
    assert stopped.relative_alt > 5000 and abs(held.relative_alt - stopped.relative_alt) < 300
    down = recv(m, "GLOBAL_POSITION_INT", 30, cond=lambda p: p.time_boot_ms - start.time_boot_ms >= 8000)
    assert down.relative_alt < held.relative_alt - 1000
    sitl.stop()
