"""ArduPilot's telemetry from `towerlink sitl`, asked for as pymavlink users ask: every
message by SET_MESSAGE_INTERVAL (arriving at that interval, measured on the vehicle's clock)
and by REQUEST_MESSAGE, ArduPilot's message set from REQUEST_DATA_STREAM ALL (Copter and
Rover), MAV_CMD_DO_SEND_BANNER's texts and AUTOPILOT_VERSION's git-hash bytes."""
from __future__ import annotations

import re
import time

import pytest

from support import Processes
from test_sitl_support import Sitl, command, connect, goto_local, mav, recv, set_mode, set_param, wait_armable

pytestmark = pytest.mark.timeout(120)

C = mav
# the messages ArduPilot sends that towerlink did not (SET_MESSAGE_INTERVAL was DENIED)
NEW = ["RAW_IMU", "SCALED_IMU2", "SCALED_PRESSURE", "SERVO_OUTPUT_RAW", "RC_CHANNELS", "NAV_CONTROLLER_OUTPUT",
       "POSITION_TARGET_GLOBAL_INT", "EKF_STATUS_REPORT", "VIBRATION", "FENCE_STATUS", "POWER_STATUS", "MEMINFO",
       "AHRS", "AHRS2", "SCALED_IMU3", "SCALED_PRESSURE2", "SIMSTATE", "WIND", "PID_TUNING", "ATTITUDE_TARGET",
       "ESC_TELEMETRY_1_TO_4"]
# what REQUEST_DATA_STREAM ALL brings from ArduCopter / ArduRover (SITL, fence on, flying,
# GCS_PID_MASK set); SITL's truth as SIMSTATE (towerlink adds SIM_STATE)
ARDUPILOT_SET = {"HEARTBEAT", "RAW_IMU", "SCALED_IMU2", "SCALED_IMU3", "SCALED_PRESSURE", "SCALED_PRESSURE2",
                 "SYS_STATUS", "POWER_STATUS", "MEMINFO", "MISSION_CURRENT", "GPS_RAW_INT", "NAV_CONTROLLER_OUTPUT",
                 "FENCE_STATUS", "SERVO_OUTPUT_RAW", "RC_CHANNELS", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED",
                 "ATTITUDE", "SIMSTATE", "SIM_STATE", "AHRS2", "PID_TUNING", "ESC_TELEMETRY_1_TO_4", "VFR_HUD", "AHRS",
                 "WIND", "SYSTEM_TIME", "BATTERY_STATUS", "EKF_STATUS_REPORT", "VIBRATION"}


def msgid(name: str) -> int:
    return getattr(C, "MAVLINK_MSG_ID_" + name)


def counts_over(m, seconds: int) -> tuple[dict[str, int], float]:
    """Messages of each type between two SYSTEM_TIMEs `seconds` apart on the vehicle's clock
    (SR0_EXTRA3 sends it at 1 Hz), and that span in s."""
    recv(m, "SYSTEM_TIME", 10)               # what was in flight before the request goes by
    t0 = recv(m, "SYSTEM_TIME", 10).time_boot_ms
    counts: dict[str, int] = {}
    while True:
        msg = recv(m, None, 10)
        if msg.get_type() == "SYSTEM_TIME" and msg.time_boot_ms - t0 >= seconds * 1000 - 50:
            return counts, (msg.time_boot_ms - t0) / 1000.0
        counts[msg.get_type()] = counts.get(msg.get_type(), 0) + 1


@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    """A copter and a rover; the copter over TCP, fence on, flying a GUIDED leg (so every
    message has content): (Sitl, the copter's connection)."""
    procs = Processes()
    try:
        s = Sitl(procs, tmp_path_factory.mktemp("telem"), drones=1, rovers=1, speedup=5)
        m = connect(s.tcp[0], tcp=True)
        wait_armable(m)
        set_param(m, "FENCE_ENABLE", 1)
        set_param(m, "FENCE_ACTION", 0)
        set_param(m, "GCS_PID_MASK", 1)                 # PID_TUNING: the roll rate controller
        assert set_mode(m, "GUIDED") == C.MAV_RESULT_ACCEPTED
        assert command(m, C.MAV_CMD_COMPONENT_ARM_DISARM, 1) == C.MAV_RESULT_ACCEPTED
        assert command(m, C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 5) == C.MAV_RESULT_ACCEPTED
        recv(m, "GLOBAL_POSITION_INT", 30, cond=lambda g: g.relative_alt > 4500)
        goto_local(m, 40, 30, -5)
        yield s, m
        m.close()
    finally:
        procs.stop_all()


@pytest.fixture(scope="module")
def flying(sitl):
    return sitl[1]


def test_set_message_interval_sends_each_message_at_its_interval(flying):
    m = flying
    for name in NEW:
        assert command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid(name), 250000) == C.MAV_RESULT_ACCEPTED, name
    counts, span = counts_over(m, 4)
    for name in NEW:
        rate = counts.get(name, 0) / span
        assert 3.0 <= rate <= 5.0, (name, counts.get(name, 0), span)
    assert command(m, C.MAV_CMD_GET_MESSAGE_INTERVAL, msgid("EKF_STATUS_REPORT")) == C.MAV_RESULT_ACCEPTED
    assert recv(m, "MESSAGE_INTERVAL", 5, cond=lambda i: i.message_id == msgid("EKF_STATUS_REPORT")).interval_us == 250000
    for asked, kept in ((50000, 50000), (33333, 33000), (400, 1000)):     # ArduPilot keeps whole ms, at least 1
        assert command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid("VIBRATION"), asked) == C.MAV_RESULT_ACCEPTED
        assert command(m, C.MAV_CMD_GET_MESSAGE_INTERVAL, msgid("VIBRATION")) == C.MAV_RESULT_ACCEPTED
        assert recv(m, "MESSAGE_INTERVAL", 5, cond=lambda i: i.message_id == msgid("VIBRATION")).interval_us == kept
    for name in NEW:                          # -1 stops them all
        assert command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid(name), -1) == C.MAV_RESULT_ACCEPTED
    counts, _ = counts_over(m, 2)
    assert not set(counts) & set(NEW), counts
    for name in NEW:                          # 0: back to the stream groups' defaults
        assert command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid(name), 0) == C.MAV_RESULT_ACCEPTED


def same_burst(m, first: str, then: str, timeout: float):
    """The next `first` that `then` follows directly: two messages of one stream group (SR0_EXTRA1
    sends ATTITUDE, then SIMSTATE), built in one tick of the world, so one instant."""
    deadline, prev = time.monotonic() + timeout, None
    while time.monotonic() < deadline:
        msg = m.recv_match(type=[first, then], blocking=True, timeout=0.5)
        if msg is not None and msg.get_type() == then and prev is not None:
            return prev, msg
        prev = msg if msg is not None and msg.get_type() == first else None
    raise AssertionError(f"no {first} followed by {then} in {timeout} s")


def test_request_message_answers_with_each(flying):
    m = flying
    got = {}
    for name in NEW + ["AUTOPILOT_VERSION"]:
        assert command(m, C.MAV_CMD_REQUEST_MESSAGE, msgid(name)) == C.MAV_RESULT_ACCEPTED, name
        got[name] = recv(m, name, 5)
    ekf = got["EKF_STATUS_REPORT"]
    assert ekf.flags == 0x33F and 0 < ekf.pos_horiz_variance < 1
    servo = got["SERVO_OUTPUT_RAW"]
    assert all(1300 < getattr(servo, f"servo{k}_raw") < 1900 for k in range(1, 5))     # flying
    assert got["FENCE_STATUS"].breach_status == 0 and got["RC_CHANNELS"].chan3_raw == 1000    # the receiver's
    assert got["POSITION_TARGET_GLOBAL_INT"].coordinate_frame == C.MAV_FRAME_GLOBAL
    assert command(m, C.MAV_CMD_REQUEST_MESSAGE, 12345) == C.MAV_RESULT_FAILED        # no such message
    # the truth against itself, the controllers against their telemetry: an ATTITUDE and the
    # SIMSTATE of the same instant (the requested SIMSTATE left a few messages ago, mid-leg)
    assert -11 < got["SIMSTATE"].zacc < -8
    att, s = same_burst(m, "ATTITUDE", "SIMSTATE", 5)
    assert abs(s.roll - att.roll) < 0.05 and abs(s.pitch - att.pitch) < 0.05 and -11 < s.zacc < -8
    assert got["PID_TUNING"].axis == C.PID_TUNING_ROLL and abs(got["PID_TUNING"].achieved - att.rollspeed) < 0.3
    assert got["WIND"].speed == 0.0 and all(2000 < r < 12000 for r in got["ESC_TELEMETRY_1_TO_4"].rpm)
    assert abs(got["ATTITUDE_TARGET"].thrust - 0.5) < 0.4 and got["SCALED_IMU3"].zacc == 0
    assert command(m, C.MAV_CMD_REQUEST_MESSAGE, msgid("SCALED_PRESSURE3")) == C.MAV_RESULT_ACCEPTED  # no 3rd baro


def test_banner_and_version_hash(sitl, flying):
    m = flying
    assert command(m, C.MAV_CMD_DO_SEND_BANNER) == C.MAV_RESULT_ACCEPTED
    texts = [recv(m, "STATUSTEXT", 5).text for _ in range(3)]
    match = re.fullmatch(r"ArduCopter V4\.5\.0 \(([0-9a-f]{8})\)", texts[0])
    assert match, texts
    assert texts[2] == "Frame: QUAD/X"
    assert command(m, C.MAV_CMD_REQUEST_MESSAGE, msgid("AUTOPILOT_VERSION")) == C.MAV_RESULT_ACCEPTED
    av = recv(m, "AUTOPILOT_VERSION", 5)
    assert bytes(av.flight_custom_version).decode("ascii") == match.group(1)
    rover = connect(sitl[0].tcp[1], tcp=True)
    assert command(rover, C.MAV_CMD_DO_SEND_BANNER) == C.MAV_RESULT_ACCEPTED
    assert recv(rover, "STATUSTEXT", 5).text == f"ArduRover V4.5.0 ({match.group(1)})"
    rover.close()


def test_request_data_stream_all_brings_ardupilots_set(sitl, flying):
    m = flying
    m.mav.request_data_stream_send(m.target_system, m.target_component, C.MAV_DATA_STREAM_ALL, 4, 1)
    counts, _ = counts_over(m, 3)
    assert ARDUPILOT_SET <= set(counts), ARDUPILOT_SET - set(counts)
    assert counts["EKF_STATUS_REPORT"] >= 9 and counts["RAW_IMU"] >= 9
    rover = connect(sitl[0].tcp[1], tcp=True)
    rover.mav.request_data_stream_send(rover.target_system, rover.target_component, C.MAV_DATA_STREAM_ALL, 4, 1)
    counts, _ = counts_over(rover, 3)
    rover_set = (ARDUPILOT_SET - {"FENCE_STATUS", "NAV_CONTROLLER_OUTPUT", "WIND", "PID_TUNING",
                                  "ESC_TELEMETRY_1_TO_4"}) | {"RC_CHANNELS_SCALED"}
    assert rover_set <= set(counts), rover_set - set(counts)
    rover.close()


def test_pid_tuning_sends_every_enabled_axis_at_the_stream_rate(flying):
    """GCS_MAVLINK_Copter::send_pid_tuning sends each axis GCS_PID_MASK enables every time
    PID_TUNING is due: with four axes at 4 Hz, each axis arrives at 4 Hz (not 1 Hz)."""
    m = flying
    set_param(m, "GCS_PID_MASK", 15)                    # roll, pitch, yaw, accel z
    try:
        assert command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid("PID_TUNING"), 250000) == C.MAV_RESULT_ACCEPTED
        recv(m, "SYSTEM_TIME", 10)
        t0 = recv(m, "SYSTEM_TIME", 10).time_boot_ms
        axes: dict[int, int] = {}
        while True:
            msg = recv(m, None, 10)
            if msg.get_type() == "SYSTEM_TIME" and msg.time_boot_ms - t0 >= 4000 - 50:
                span = (msg.time_boot_ms - t0) / 1000.0
                break
            if msg.get_type() == "PID_TUNING":
                axes[msg.axis] = axes.get(msg.axis, 0) + 1
        assert sorted(axes) == [C.PID_TUNING_ROLL, C.PID_TUNING_PITCH, C.PID_TUNING_YAW, C.PID_TUNING_ACCZ], axes
        for axis, n in axes.items():
            assert 3.0 <= n / span <= 5.0, (axis, n, span)
        assert command(m, C.MAV_CMD_REQUEST_MESSAGE, msgid("PID_TUNING")) == C.MAV_RESULT_ACCEPTED
    finally:
        command(m, C.MAV_CMD_SET_MESSAGE_INTERVAL, msgid("PID_TUNING"), 0)
        set_param(m, "GCS_PID_MASK", 1)
