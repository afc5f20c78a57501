"""Issue 10's modes and commands over loopback with pymavlink, as an ArduPilot script drives
them: every built-in mode entered disarmed (drone and rover), BRAKE / ALT_HOLD / POSHOLD /
SMART_RTL in flight with their behaviour read back from LOCAL_POSITION_NED (sim-time stamped),
DO_REPOSITION (COMMAND_INT and COMMAND_LONG), REQUEST_MESSAGE(GPS_GLOBAL_ORIGIN),
CONDITION_YAW / DO_SET_HOME / DO_PAUSE_CONTINUE in GUIDED, DO_FLIGHTTERMINATION."""
from __future__ import annotations

import math

import pytest

from support import Processes
from test_sitl_guided import _take_off
from test_sitl_support import Sitl, command, connect, hold_throttle, mav, recv, set_mode, wait_armable

VEL_MASK = 0b110111000111


def _speed(p) -> float:
    return math.hypot(p.vx, p.vy)


def _cruise(m, speed=5.0, timeout=30):
    """GUIDED velocity north until LOCAL_POSITION_NED shows it (re-sent within GUID_TIMEOUT)."""
    for _ in range(int(timeout)):
        m.mav.set_position_target_local_ned_send(0, 1, 1, mav.MAV_FRAME_LOCAL_NED, VEL_MASK,
                                                 0, 0, 0, speed, 0, 0, 0, 0, 0, 0, 0)
        try:
            return recv(m, "LOCAL_POSITION_NED", 1.0, cond=lambda p: p.vx > speed - 0.1 and abs(p.vy) < 0.15)
        except AssertionError:
            continue
    raise AssertionError("never reached cruise speed")


@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    procs = Processes()
    try:
        s = Sitl(procs, tmp_path_factory.mktemp("modes"), drones=1, rovers=1, speedup=5)
        yield s, connect(s.udp[0]), connect(s.udp[1])
    finally:
        procs.stop_all()


def _hb_mode(m, number, timeout=5):
    return recv(m, "HEARTBEAT", timeout, cond=lambda h: h.get_srcSystem() == m.target_system
                and h.custom_mode == number)


@pytest.mark.timeout(120)
def test_every_built_in_mode_disarmed(sitl):
    _s, drone, rover = sitl
    for m, names in ((drone, ["STABILIZE", "ALT_HOLD", "GUIDED", "LOITER", "RTL", "LAND", "POSHOLD",
                                         "BRAKE", "SMART_RTL", "STABILIZE"]),
                                (rover, ["MANUAL", "ACRO", "STEERING", "LOITER", "SMART_RTL", "GUIDED", "RTL",
                                         "HOLD"])):
        wait_armable(m, 30)
        mapping = m.mode_mapping()
        for name in names:
            assert set_mode(m, name) == mav.MAV_RESULT_ACCEPTED, name
            _hb_mode(m, mapping[name])
            hb = recv(m, "HEARTBEAT", 5, cond=lambda h: h.get_srcSystem() == m.target_system)
            assert not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED
        # FOLLOW without FOLL_ENABLE: refused in ArduPilot's words (the texts come first);
        # with it, accepted (vehicle/autopilot/follow_mode.py, tests/test_follow_mode.py)
        m.set_mode("FOLLOW")
        texts = []
        while True:
            msg = recv(m, ["COMMAND_ACK", "STATUSTEXT"], 5)
            if msg.get_type() == "COMMAND_ACK":
                break
            texts.append(msg.text)
        assert msg.result == mav.MAV_RESULT_FAILED
        assert texts == (["Set FOLL_ENABLE = 1", "Mode change to FOLLOW failed: init failed"] if m is drone
                         else ["Flight mode change failed"]), texts
        m.mav.param_set_send(m.target_system, 1, b"FOLL_ENABLE", 1, mav.MAV_PARAM_TYPE_INT8)
        recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "FOLL_ENABLE" and p.param_value == 1)
        assert set_mode(m, "FOLLOW") == mav.MAV_RESULT_ACCEPTED
        _hb_mode(m, mapping["FOLLOW"])


@pytest.mark.timeout(150)
def test_brake_alt_hold_poshold_in_flight(sitl):
    _s, m, _r = sitl
    _take_off(m, alt=10.0)
    _cruise(m, 5.0)
    assert set_mode(m, "BRAKE") == mav.MAV_RESULT_ACCEPTED
    t0 = recv(m, "LOCAL_POSITION_NED", 2)
    # stopped: northward speed under 0.1 m/s (10 Hz samples; the speed magnitude can step over
    # 0.1 m/s as the velocity crosses zero)
    stop = recv(m, "LOCAL_POSITION_NED", 15, cond=lambda p: p.vx < 0.1)
    took, dist = (stop.time_boot_ms - t0.time_boot_ms) / 1000.0, math.hypot(stop.x - t0.x, stop.y - t0.y)
    print(f"BRAKE over the wire from 5 m/s: {took:.2f} s (sim) and {dist:.2f} m to < 0.1 m/s")
    # ArduPilot: 7.5 m/s/s capped by ANGLE_MAX 30 deg (5.66), jerk 5 m/s/s/s: 2.0 s and 5.0 m ideal
    assert took <= 2.6 and dist <= 6.5
    assert abs(stop.z - t0.z) < 0.3
    held = recv(m, "LOCAL_POSITION_NED", 20, cond=lambda p: p.time_boot_ms > stop.time_boot_ms + 8000)
    assert math.hypot(held.x - stop.x, held.y - stop.y) < 1.0 and _speed(held) < 0.2

    # ALT_HOLD: sticks centred (the throttle raised to mid stick), altitude held while it drifts
    _take_off(m, alt=10.0)
    _cruise(m, 3.0)
    hold_throttle(m, 1500)
    assert set_mode(m, "ALT_HOLD") == mav.MAV_RESULT_ACCEPTED
    a0 = recv(m, "LOCAL_POSITION_NED", 2)
    a1 = recv(m, "LOCAL_POSITION_NED", 20, cond=lambda p: p.time_boot_ms > a0.time_boot_ms + 10000)
    assert abs(a1.z - a0.z) < 0.5

    # POSHOLD: brakes, then holds where it stopped
    _take_off(m, alt=10.0)
    _cruise(m, 5.0)
    assert set_mode(m, "POSHOLD") == mav.MAV_RESULT_ACCEPTED
    s = recv(m, "LOCAL_POSITION_NED", 20, cond=lambda p: p.vx < 0.1)
    h = recv(m, "LOCAL_POSITION_NED", 30, cond=lambda p: p.time_boot_ms > s.time_boot_ms + 10000)
    assert math.hypot(h.x - s.x, h.y - s.y) < 1.5 and abs(h.z - s.z) < 0.3
    hold_throttle(m, 0)                      # back to the receiver's throttle


@pytest.mark.timeout(200)
def test_smart_rtl_retraces_and_lands(sitl):
    _s, m, _r = sitl
    _take_off(m, alt=6.0)
    home = recv(m, "HOME_POSITION", 5)
    for x, y in ((30, 0), (30, 30)):
        m.mav.set_position_target_local_ned_send(0, 1, 1, mav.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                                 x, y, -6, 0, 0, 0, 0, 0, 0, 0, 0)
        recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: math.hypot(p.x - x, p.y - y) < 0.5)
    assert set_mode(m, "SMART_RTL") == mav.MAV_RESULT_ACCEPTED
    trace = []
    while True:
        msg = recv(m, ["LOCAL_POSITION_NED", "HEARTBEAT"], 120)
        if msg.get_type() == "LOCAL_POSITION_NED":
            trace.append((msg.x, msg.y))
        elif msg.get_srcSystem() == 1 and not msg.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED:
            break
    # back the way it came: by the corner (30, 0), never the diagonal home
    assert min(math.hypot(x - 30, y) for x, y in trace) < 3.0
    assert min(math.hypot(x - 15, y - 15) for x, y in trace) > 8.0
    end = recv(m, "LOCAL_POSITION_NED", 5)
    assert math.hypot(end.x - home.x, end.y - home.y) < 1.5


@pytest.mark.timeout(150)
def test_do_reposition_and_guided_commands(sitl):
    _s, m, _r = sitl
    _take_off(m, alt=5.0)
    home = recv(m, "HOME_POSITION", 5)
    assert set_mode(m, "LOITER") == mav.MAV_RESULT_ACCEPTED
    lat = home.latitude + int(15 / 111_319.5 * 1e7)
    # not in GUIDED and no CHANGE_MODE flag: DENIED
    m.mav.command_int_send(1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0,
                           -1, 0, 0, math.nan, lat, home.longitude, 7.0)
    assert recv(m, "COMMAND_ACK", 5, cond=lambda a: a.command == mav.MAV_CMD_DO_REPOSITION).result \
        == mav.MAV_RESULT_DENIED
    # MAVSDK's and QGC's way: COMMAND_INT, CHANGE_MODE flag: GUIDED, and it flies there
    m.mav.command_int_send(1, 1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0,
                           -1, mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, math.nan, lat, home.longitude, 7.0)
    assert recv(m, "COMMAND_ACK", 5, cond=lambda a: a.command == mav.MAV_CMD_DO_REPOSITION).result \
        == mav.MAV_RESULT_ACCEPTED
    _hb_mode(m, 4)
    recv(m, "GLOBAL_POSITION_INT", 40, cond=lambda g: abs(g.lat - lat) * 0.0111 < 0.5
         and abs(g.lon - home.longitude) * 0.0111 < 0.5 and abs(g.relative_alt - 7000) < 500)
    # COMMAND_LONG: degrees in param5/6, AMSL altitude
    m.mav.command_long_send(1, 1, mav.MAV_CMD_DO_REPOSITION, 0, -1, 1, 0, math.nan, home.latitude * 1e-7,
                            home.longitude * 1e-7, home.altitude / 1000.0 + 6.0)
    assert recv(m, "COMMAND_ACK", 5, cond=lambda a: a.command == mav.MAV_CMD_DO_REPOSITION).result \
        == mav.MAV_RESULT_ACCEPTED
    recv(m, "LOCAL_POSITION_NED", 40, cond=lambda p: math.hypot(p.x - home.x, p.y - home.y) < 0.5
         and abs(p.z - (home.z - 6.0)) < 0.5)

    # CONDITION_YAW in GUIDED: to 90 deg absolute
    assert command(m, mav.MAV_CMD_CONDITION_YAW, 90, 30, 1, 0) == mav.MAV_RESULT_ACCEPTED
    recv(m, "ATTITUDE", 20, cond=lambda a: abs(math.degrees(a.yaw) - 90) < 3)
    # DO_PAUSE_CONTINUE in GUIDED: pause a move, it stops; continue, it arrives
    m.mav.set_position_target_local_ned_send(0, 1, 1, mav.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                             home.x + 40, home.y, home.z - 6, 0, 0, 0, 0, 0, 0, 0, 0)
    recv(m, "LOCAL_POSITION_NED", 20, cond=lambda p: p.vx > 3)
    assert command(m, mav.MAV_CMD_DO_PAUSE_CONTINUE, 0) == mav.MAV_RESULT_ACCEPTED
    s = recv(m, "LOCAL_POSITION_NED", 15, cond=lambda p: _speed(p) < 0.1)
    later = recv(m, "LOCAL_POSITION_NED", 10, cond=lambda p: p.time_boot_ms > s.time_boot_ms + 3000)
    assert abs(later.x - s.x) < 1.0 and later.x < home.x + 35
    assert command(m, mav.MAV_CMD_DO_PAUSE_CONTINUE, 1) == mav.MAV_RESULT_ACCEPTED
    recv(m, "LOCAL_POSITION_NED", 30, cond=lambda p: abs(p.x - (home.x + 40)) < 0.5)
    # DO_SET_HOME to here (param1 1): HOME_POSITION moves 40 m north
    assert command(m, mav.MAV_CMD_DO_SET_HOME, 1) == mav.MAV_RESULT_ACCEPTED
    recv(m, "HOME_POSITION", 10, cond=lambda h: abs(h.x - (home.x + 40)) < 1.0)

    # GPS_GLOBAL_ORIGIN on request: the ACK, then the message
    assert command(m, mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN) == mav.MAV_RESULT_ACCEPTED
    o = recv(m, "GPS_GLOBAL_ORIGIN", 2)
    # LOCAL_POSITION_NED is metres from that origin: same instant, same place as GLOBAL_POSITION_INT
    g = recv(m, "GLOBAL_POSITION_INT", 2)
    p = recv(m, "LOCAL_POSITION_NED", 2, cond=lambda q: q.time_boot_ms == g.time_boot_ms)
    assert abs((g.lat - o.latitude) * 1e-7 * 111_319.5 - p.x) < 0.5
    assert abs((g.alt - o.altitude) / 1000.0 + p.z) < 0.5

    # DO_FLIGHTTERMINATION: disarmed at once
    assert command(m, mav.MAV_CMD_DO_FLIGHTTERMINATION, 1) == mav.MAV_RESULT_ACCEPTED
    recv(m, "HEARTBEAT", 5, cond=lambda h: h.get_srcSystem() == 1 and not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)


STREAMED_OR_ASKED = ["HEARTBEAT", "SYS_STATUS", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED",
                     "ATTITUDE", "ATTITUDE_QUATERNION", "VFR_HUD", "HOME_POSITION", "EXTENDED_SYS_STATE",
                     "SYSTEM_TIME", "BATTERY_STATUS", "POSITION_TARGET_LOCAL_NED", "SIM_STATE", "MISSION_CURRENT",
                     "GPS_GLOBAL_ORIGIN", "AUTOPILOT_VERSION", "RAW_IMU", "SCALED_IMU2", "SCALED_PRESSURE",
                     "SERVO_OUTPUT_RAW", "RC_CHANNELS", "RC_CHANNELS_SCALED", "EKF_STATUS_REPORT", "VIBRATION",
                     "POWER_STATUS", "MEMINFO", "AHRS", "AHRS2"]     # the rover's (NAV_CONTROLLER_OUTPUT: only in AUTO...)


@pytest.mark.timeout(120)
def test_request_message_for_every_message_the_vehicle_sends(sitl):
    _s, _d, m = sitl
    wait_armable(m, 30)
    for name in STREAMED_OR_ASKED:
        msgid = getattr(mav, f"MAVLINK_MSG_ID_{name}")
        if name != "AUTOPILOT_VERSION":          # stop its stream, so what arrives was asked for
            assert command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, -1) == mav.MAV_RESULT_ACCEPTED
            while m.recv_match(type=name, blocking=False) is not None:
                pass
        m.mav.command_long_send(m.target_system, 1, mav.MAV_CMD_REQUEST_MESSAGE,
                                0, msgid, 0, 0, 0, 0, 0, 0)
        got = []
        while not any(g.get_type() == name for g in got):
            got.append(recv(m, ["COMMAND_ACK", name], 3))
        acks = [g for g in got if g.get_type() == "COMMAND_ACK" and g.command == mav.MAV_CMD_REQUEST_MESSAGE]
        assert acks and acks[0].result == mav.MAV_RESULT_ACCEPTED, name
        assert got.index(acks[0]) < next(i for i, g in enumerate(got) if g.get_type() == name), name
        if name != "AUTOPILOT_VERSION":
            assert command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, 0) == mav.MAV_RESULT_ACCEPTED
    # an id the vehicle has no message for (ArduPilot never sends MANUAL_CONTROL): FAILED, as ArduPilot
    assert command(m, mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_MANUAL_CONTROL) == mav.MAV_RESULT_FAILED


@pytest.mark.timeout(90)
def test_gps_global_origin_sent_when_it_is_set(sitl):
    _s, _d, m = sitl
    recv(m, "HEARTBEAT", 5, cond=lambda h: not h.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
    # a reboot forgets the EKF origin; it is set again with the first good estimate, and said
    assert command(m, mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == mav.MAV_RESULT_ACCEPTED
    o = recv(m, "GPS_GLOBAL_ORIGIN", 20)
    hp = recv(m, "HOME_POSITION", 10)
    assert o.latitude != 0 and abs(o.latitude - hp.latitude) * 1e-7 * 111_319.5 < 50
