"""MAVLink surface of `towerlink sitl` over loopback: acks, pre-arm, params, streams,
requests, TIMESYNC, several clients, other sysids, and garbage input."""
from __future__ import annotations

import socket
import struct
import time

import pytest

from support import Processes
from test_sitl_support import Sitl, collect, command, connect, mav, recv, set_mode, wait_armable

pytestmark = pytest.mark.timeout(90)


@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    procs = Processes()
    try:
        yield Sitl(procs, tmp_path_factory.mktemp("sitl"), drones=1, rovers=1, speedup=5)
    finally:
        procs.stop_all()


@pytest.fixture(scope="module")
def drone(sitl):
    m = connect(sitl.udp[0])
    wait_armable(m)
    yield m
    m.close()


def test_heartbeat_modes_and_types(sitl, drone):
    hb = recv(drone, "HEARTBEAT", 5)
    assert hb.type == mav.MAV_TYPE_QUADROTOR and hb.autopilot == mav.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert hb.base_mode & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert hb.system_status == mav.MAV_STATE_STANDBY
    assert drone.mode_mapping()["LAND"] == 9 and drone.mode_mapping()["RTL"] == 6
    rover = connect(sitl.udp[1])
    hb = recv(rover, "HEARTBEAT", 5)
    assert rover.target_system == 2 and hb.type == mav.MAV_TYPE_GROUND_ROVER and hb.custom_mode == 4  # HOLD
    assert set_mode(rover, "MANUAL") == mav.MAV_RESULT_ACCEPTED
    recv(rover, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 0)
    assert set_mode(rover, "HOLD") == mav.MAV_RESULT_ACCEPTED
    rover.close()


def test_command_ack_each_result(drone):
    assert command(drone, 203) == mav.MAV_RESULT_UNSUPPORTED                  # DO_DIGICAM_CONTROL
    assert command(drone, mav.MAV_CMD_DO_SET_MODE, 0, 4) == mav.MAV_RESULT_DENIED   # no CUSTOM flag
    assert command(drone, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 5) == mav.MAV_RESULT_FAILED  # disarmed
    # AUTO with no mission: disarmed, accepted (ArduCopter: ignore_checks = !armed)
    assert command(drone, mav.MAV_CMD_DO_SET_MODE, 1, 3) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_DO_SET_MODE, 1, 15) == mav.MAV_RESULT_FAILED   # AUTOTUNE: no such mode
    assert command(drone, mav.MAV_CMD_DO_SET_MODE, 1, 4) == mav.MAV_RESULT_ACCEPTED  # GUIDED
    assert command(drone, mav.MAV_CMD_DO_CHANGE_SPEED, 0, 4, -1) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_DO_CHANGE_SPEED, 0, -5, -1) == mav.MAV_RESULT_FAILED
    assert command(drone, mav.MAV_CMD_DO_CHANGE_SPEED, 0, -1, -1) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 1) == mav.MAV_RESULT_TEMPORARILY_REJECTED
    assert command(drone, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED  # on the ground
    # exactly one ack per command
    drone.mav.command_long_send(1, 1, 203, 0, 0, 0, 0, 0, 0, 0, 0)
    drone.mav.command_long_send(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
    drone.mav.command_long_send(1, 1, mav.MAV_CMD_USER_1, 0, 0, 0, 0, 0, 0, 0, 0)   # a marker, handled after
    acks = [a.command for a in _until_marker_and_two_ticks(drone, mav.MAV_CMD_USER_1)]
    assert sorted(acks) == sorted([203, mav.MAV_CMD_DO_SET_MODE, mav.MAV_CMD_USER_1])
    # COMMAND_INT too
    drone.mav.command_int_send(1, 1, 0, 203, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    assert recv(drone, "COMMAND_ACK", 5, cond=lambda a: a.command == 203).result == mav.MAV_RESULT_UNSUPPORTED
    # SET_MODE message is acked like ArduPilot (command = 11)
    drone.mav.set_mode_send(1, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 5)
    assert recv(drone, "COMMAND_ACK", 5, cond=lambda a: a.command == 11).result == mav.MAV_RESULT_ACCEPTED
    recv(drone, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 5)
    assert set_mode(drone, "GUIDED") == mav.MAV_RESULT_ACCEPTED


def test_prearm_failure_statustext(drone):
    assert set_mode(drone, "LAND") == mav.MAV_RESULT_ACCEPTED
    drone.arducopter_arm()
    ack = texts = None
    texts = []
    while ack is None:
        msg = recv(drone, ["COMMAND_ACK", "STATUSTEXT"], 5)
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.command == 400:
            ack = msg
    assert ack.result == mav.MAV_RESULT_FAILED
    assert "PreArm: Mode not armable" in texts
    # force arm like ArduPilot (param2 = 21196), then disarm
    assert command(drone, 400, 1, 21196) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, 400, 0, 21196) == mav.MAV_RESULT_ACCEPTED
    assert set_mode(drone, "GUIDED") == mav.MAV_RESULT_ACCEPTED


def test_sys_status_gps_raw_home_and_capabilities(drone):
    s = recv(drone, "SYS_STATUS", 5)
    for bit in (mav.MAV_SYS_STATUS_SENSOR_GPS, mav.MAV_SYS_STATUS_PREARM_CHECK):
        assert s.onboard_control_sensors_present & bit and s.onboard_control_sensors_health & bit
    g = recv(drone, "GPS_RAW_INT", 5)
    assert g.fix_type == 3 and abs(g.lat * 1e-7 + 35.363261) < 1e-3
    assert command(drone, mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_HOME_POSITION) == mav.MAV_RESULT_ACCEPTED
    h = recv(drone, "HOME_POSITION", 5)
    assert abs(h.latitude * 1e-7 + 35.363261) < 1e-4
    assert command(drone, mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1) == mav.MAV_RESULT_ACCEPTED
    v = recv(drone, "AUTOPILOT_VERSION", 5)
    for cap in (mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2, mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
                mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED, mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
                mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT, mav.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET,
                mav.MAV_PROTOCOL_CAPABILITY_FTP):                  # MAVSDK and QGC read it before FTP
        assert v.capabilities & cap
    assert command(drone, mav.MAV_CMD_REQUEST_MESSAGE, 99999) == mav.MAV_RESULT_FAILED
    e = recv(drone, "EXTENDED_SYS_STATE", 5)
    assert e.landed_state == mav.MAV_LANDED_STATE_ON_GROUND
    st = recv(drone, "SYSTEM_TIME", 5)
    assert abs(st.time_unix_usec / 1e6 - time.time()) < 3600
    recv(drone, "BATTERY_STATUS", 5)
    recv(drone, "SIM_STATE", 5)
    recv(drone, "ATTITUDE_QUATERNION", 5)
    recv(drone, "VFR_HUD", 5)


def _rate(m, typ, n=12, timeout=10):
    """Messages per sim second from time_boot_ms of n consecutive messages."""
    first = recv(m, typ, timeout)
    last = first
    for _ in range(n - 1):
        last = recv(m, typ, timeout)
    return (n - 1) / ((last.time_boot_ms - first.time_boot_ms) / 1000.0)


def test_stream_rates_change_on_the_wire(drone):
    assert command(drone, mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, 40000) == mav.MAV_RESULT_ACCEPTED
    r = _rate(drone, "ATTITUDE", 30)
    assert 20 < r < 30, r
    assert command(drone, mav.MAV_CMD_GET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE) == mav.MAV_RESULT_ACCEPTED
    assert recv(drone, "MESSAGE_INTERVAL", 5).interval_us == 40000
    assert command(drone, mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, -1) == mav.MAV_RESULT_ACCEPTED
    recv(drone, "HEARTBEAT", 5)
    # what was already in flight is discarded while two SYSTEM_TIMEs go by after the change
    recv(drone, "SYSTEM_TIME", 5)
    recv(drone, "SYSTEM_TIME", 5)
    while drone.recv_match(type="ATTITUDE", blocking=False):
        pass
    # then none over 2 s of the vehicle's clock (three SYSTEM_TIMEs at SR0_EXTRA3 = 1 Hz;
    # at 25 Hz that would have been ~50 ATTITUDE), not over a wall-clock window
    got = collect(drone, ["ATTITUDE", "SYSTEM_TIME"],
                  lambda g: sum(m.get_type() == "SYSTEM_TIME" for m in g) >= 3)
    times = [m.time_boot_ms for m in got if m.get_type() == "SYSTEM_TIME"]
    assert times[-1] - times[0] >= 1900, times
    assert [m for m in got if m.get_type() == "ATTITUDE"] == []
    assert command(drone, mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAVLINK_MSG_ID_ATTITUDE, 0) == mav.MAV_RESULT_ACCEPTED
    r = _rate(drone, "ATTITUDE", 12)
    assert 7 < r < 13, r            # back to SR0_EXTRA1 = 10 Hz
    assert command(drone, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 12345) == mav.MAV_RESULT_DENIED
    # REQUEST_DATA_STREAM (as MAVProxy does): EXTRA2 (VFR_HUD) to 2 Hz and back to 4 Hz
    drone.mav.request_data_stream_send(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 2, 1)
    recv(drone, "SYSTEM_TIME", 5)     # the request is handled before the next tick's stream
    recv(drone, "SYSTEM_TIME", 5)
    r = recv(drone, "VFR_HUD", 5)
    # VFR_HUD has no timestamp: time it against SYSTEM_TIME on the same stream
    t0 = recv(drone, "SYSTEM_TIME", 5).time_boot_ms
    n = 0
    while True:
        msg = recv(drone, ["VFR_HUD", "SYSTEM_TIME"], 10)
        if msg.get_type() == "VFR_HUD":
            n += 1
        elif msg.time_boot_ms - t0 >= 5000:
            break
    assert 8 <= n <= 12, n
    drone.mav.request_data_stream_send(1, 1, mav.MAV_DATA_STREAM_EXTRA2, 4, 1)


def test_timesync_and_system_time(drone):
    drone.mav.timesync_send(0, 123456789)
    ts = recv(drone, "TIMESYNC", 5, cond=lambda t: t.ts1 == 123456789)
    st = recv(drone, "SYSTEM_TIME", 5)
    assert ts.tc1 > 0 and abs(ts.tc1 / 1e6 - st.time_boot_ms) < 5000


def test_params_list_read_set_refuse(drone):
    drone.mav.param_request_list_send(1, 1)
    got = {}
    first = recv(drone, "PARAM_VALUE", 5)
    count = first.param_count
    got[first.param_index] = first
    while len(got) < count:
        p = recv(drone, "PARAM_VALUE", 5)
        assert p.param_count == count
        got[p.param_index] = p
    assert sorted(got) == list(range(count))
    names = {p.param_id: p for p in got.values()}
    for n in ("SYSID_THISMAV", "FS_GCS_ENABLE", "FS_GCS_TIMEOUT", "RTL_ALT", "DISARM_DELAY",
              "SR0_EXTRA1", "WPNAV_SPEED", "ANGLE_MAX"):
        assert n in names, n
    assert names["SYSID_THISMAV"].param_value == 1
    idx = names["RTL_ALT"].param_index
    drone.mav.param_request_read_send(1, 1, b"", idx)
    assert recv(drone, "PARAM_VALUE", 5).param_id == "RTL_ALT"
    drone.mav.param_request_read_send(1, 1, b"WPNAV_SPEED", -1)
    p = recv(drone, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "WPNAV_SPEED")
    assert p.param_value == 500 and p.param_index == names["WPNAV_SPEED"].param_index
    drone.mav.param_set_send(1, 1, b"RTL_ALT", 2000, mav.MAV_PARAM_TYPE_INT32)
    assert recv(drone, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 2000
    drone.mav.param_set_send(1, 1, b"RTL_ALT", 5, mav.MAV_PARAM_TYPE_INT32)   # below 30 cm
    got = collect(drone, ["PARAM_VALUE", "STATUSTEXT"], lambda g: any(
        x.get_type() == "PARAM_VALUE" and x.param_id == "RTL_ALT" for x in g) and any(
        x.get_type() == "STATUSTEXT" and "RTL_ALT" in x.text for x in g))
    assert [x.param_value for x in got if x.get_type() == "PARAM_VALUE" and x.param_id == "RTL_ALT"] == [2000]
    assert any("out of range" in x.text for x in got if x.get_type() == "STATUSTEXT")
    drone.mav.param_set_send(1, 1, b"ANGLE_MAX", float("nan"), mav.MAV_PARAM_TYPE_REAL32)
    assert recv(drone, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "ANGLE_MAX").param_value == 3000
    drone.mav.param_set_send(1, 1, b"RTL_ALT", 1500, mav.MAV_PARAM_TYPE_INT32)
    assert recv(drone, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_value == 1500


def test_two_clients_tcp_and_udp(sitl, drone):
    t = connect(sitl.tcp[0], tcp=True, sysid=200)
    recv(t, "ATTITUDE", 5)
    recv(drone, "ATTITUDE", 5)
    t.mav.command_long_send(1, 1, 203, 0, 0, 0, 0, 0, 0, 0, 0)
    assert recv(t, "COMMAND_ACK", 5, cond=lambda a: a.command == 203).target_system == 200
    t.close()


def _until_marker_and_two_ticks(m, marker: int) -> list:
    """Every COMMAND_ACK up to the marker command's ack and two SYSTEM_TIMEs after it.

    The vehicle handles commands in the order they arrive, so anything it answers to the
    commands sent before the marker arrives first; two SYSTEM_TIMEs more are later ticks
    of its own clock (a late or repeated answer would show). No wall-clock window."""
    def done(got):
        i = next((k for k, g in enumerate(got) if g.get_type() == "COMMAND_ACK" and g.command == marker), None)
        return i is not None and sum(g.get_type() == "SYSTEM_TIME" for g in got[i:]) >= 2
    return [g for g in collect(m, ["COMMAND_ACK", "SYSTEM_TIME"], done) if g.get_type() == "COMMAND_ACK"]


def test_other_target_system_ignored(drone):
    drone.mav.command_long_send(99, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 5, 0, 0, 0, 0, 0)
    drone.mav.set_mode_send(99, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 5)
    drone.mav.command_long_send(1, 1, mav.MAV_CMD_USER_1, 0, 0, 0, 0, 0, 0, 0, 0)   # a marker, handled after
    acks = [a.command for a in _until_marker_and_two_ticks(drone, mav.MAV_CMD_USER_1)]
    assert acks == [mav.MAV_CMD_USER_1]
    assert recv(drone, "HEARTBEAT", 5).custom_mode == 4
    # broadcast target 0 is accepted
    assert command(drone, 203) == mav.MAV_RESULT_UNSUPPORTED


def _frame(msgid: int, payload: bytes, crc_extra: int, seq=0, sysid=255, comp=0) -> bytes:
    from pymavlink.generator.mavcrc import x25crc
    hdr = struct.pack("<BBBBBBBHB", 253, len(payload), 0, 0, seq, sysid, comp, msgid & 0xFFFF, msgid >> 16)
    crc = x25crc(hdr[1:] + payload)
    crc.accumulate(bytes([crc_extra]))
    return hdr + payload + struct.pack("<H", crc.crc)


def _counter(m, name, at_least, timeout=10):
    return recv(m, "NAMED_VALUE_INT", timeout, cond=lambda v: v.name == name and v.value >= at_least).value


def test_garbage_counted_and_dropped(sitl, drone):
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    dst = ("127.0.0.1", sitl.udp[0])
    good = drone.mav.heartbeat_encode(6, 8, 0, 0, 0).pack(drone.mav)
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    for _ in range(3):
        s.sendto(b"\x00\x01garbage bytes\xff" * 3, dst)
        s.sendto(bytes(bad_crc), dst)
        s.sendto(good[:7], dst)                         # truncated
        s.sendto(_frame(60000, b"\x01\x02\x03", 0), dst)  # unknown message id
        s.sendto(bytes(range(256)) * 4, dst)
    s.close()
    assert _counter(drone, "RX_BADCRC", 3) >= 3
    assert _counter(drone, "RX_GARBAGE", 3) >= 3
    assert _counter(drone, "RX_TRUNC", 3) >= 3
    assert _counter(drone, "RX_UNKNOWN", 3) >= 3
    # still serving
    recv(drone, "HEARTBEAT", 5)
    assert command(drone, 203) == mav.MAV_RESULT_UNSUPPORTED
    assert sitl.proc.poll() is None
