"""Over the wire with pymavlink, as a companion-computer script writes it: SET_ATTITUDE_TARGET
in GUIDED (thrust 0.7 lifts off, a 20 deg roll is flown, the GUID_OPTIONS timeout levels and
holds), GUIDED_NOGPS by name, and AUTO's corner cases and the unknown-mode and gripper
answers in ArduCopter's words (COMMAND_ACK results and STATUSTEXT)."""
from __future__ import annotations

import math
import time

import pytest

from test_attitude_target import q_wxyz
from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, wait_armable

LEVEL_MASK = 0b111                  # body rates ignored: attitude + thrust (MAVSDK's set_attitude)


def attitude(m, roll_deg=0.0, pitch_deg=0.0, yaw=0.0, thrust=0.5) -> None:
    m.mav.set_attitude_target_send(0, m.target_system, m.target_component, LEVEL_MASK,
                                   q_wxyz(math.radians(roll_deg), math.radians(pitch_deg), yaw),
                                   0.0, 0.0, 0.0, thrust)


def fly_until(m, target: dict, cond, timeout: float, what: str, period: float = 0.1):
    """Send the attitude target every `period` wall s until cond(ATTITUDE or
    LOCAL_POSITION_NED message) holds; that message."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        attitude(m, **target)
        end = time.monotonic() + period
        while time.monotonic() < end:
            msg = m.recv_match(type=["ATTITUDE", "LOCAL_POSITION_NED"], blocking=True, timeout=0.05)
            if msg is not None and cond(msg):
                return msg
    raise AssertionError(f"timed out: {what}")


def texts_until_ack(m, cmd: int, timeout: float = 5.0) -> tuple[int, list[str]]:
    """The STATUSTEXTs before `cmd`'s COMMAND_ACK, and its result."""
    texts = []
    while True:
        msg = recv(m, ["COMMAND_ACK", "STATUSTEXT"], timeout)
        if msg.get_type() == "COMMAND_ACK" and msg.command == cmd:
            return msg.result, texts
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)


def drone(processes, tmp_path):
    """A world of one drone at 5x, connected, ready to arm."""
    m = connect(Sitl(processes, tmp_path, drones=1, rovers=0, speedup=5).udp[0])
    wait_armable(m, 30)
    return m


@pytest.mark.timeout(150)
def test_attitude_targets_over_the_wire(processes, tmp_path):
    m = drone(processes, tmp_path)
    # GUIDED_NOGPS is a mode of this vehicle by pymavlink's name (20)
    assert set_mode(m, "GUIDED_NOGPS") == mav.MAV_RESULT_ACCEPTED
    recv(m, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 20)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    # level, thrust 0.7: a 1 m/s climb (WPNAV_SPEED_UP 2.5 m/s): off the ground
    fly_until(m, dict(thrust=0.7), lambda p: p.get_type() == "LOCAL_POSITION_NED" and p.z < -6.0, 40, "climb")
    hold = fly_until(m, dict(thrust=0.5), lambda p: p.get_type() == "LOCAL_POSITION_NED" and abs(p.vz) < 0.1,
                     20, "climb rate 0")
    # a 20 deg roll, altitude held
    fly_until(m, dict(roll_deg=20.0), lambda a: a.get_type() == "ATTITUDE" and abs(math.degrees(a.roll) - 20) < 1.0,
              20, "20 deg of roll")
    rolls = []
    fly_until(m, dict(roll_deg=20.0), lambda a: a.get_type() == "ATTITUDE"
              and (rolls.append(math.degrees(a.roll)) or len(rolls) > 15), 20, "roll samples")
    assert all(abs(r - 20.0) < 1.5 for r in rolls[-10:]), rolls
    # the vehicle's clock (sim time) now; the last target went out up to 0.1 s wall before
    # (0.5 s sim at 5x)
    last = recv(m, "ATTITUDE", 2).time_boot_ms
    # no more targets: GUID_TIMEOUT (3 s) later it levels and holds its altitude, still GUIDED
    leveling = recv(m, "ATTITUDE", 10, cond=lambda a: abs(math.degrees(a.roll)) < 15.0)
    assert 2.4 <= (leveling.time_boot_ms - last) / 1000.0 <= 4.0
    a = recv(m, "ATTITUDE", 5, cond=lambda a: abs(math.degrees(a.roll)) < 1.0)
    p = recv(m, "LOCAL_POSITION_NED", 5)
    assert abs(p.z - hold.z) < 1.0 and abs(a.pitch) < math.radians(1.5)
    hb = recv(m, "HEARTBEAT", 5, cond=lambda h: h.get_srcSystem() == m.target_system)
    assert hb.custom_mode == 4 and hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED


@pytest.mark.timeout(90)
def test_auto_corner_cases_unknown_modes_and_gripper_over_the_wire(processes, tmp_path):
    m = drone(processes, tmp_path)
    # disarmed, no mission: AUTO accepted (ArduCopter's ignore_checks = !armed)...
    assert set_mode(m, "AUTO") == mav.MAV_RESULT_ACCEPTED
    recv(m, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 3)
    # ... and arming there says why not
    m.mav.param_set_send(m.target_system, 1, b"AUTO_OPTIONS", 1, mav.MAV_PARAM_TYPE_INT32)
    recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "AUTO_OPTIONS" and p.param_value == 1)
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    result, texts = texts_until_ack(m, mav.MAV_CMD_COMPONENT_ARM_DISARM)
    assert result == mav.MAV_RESULT_FAILED and "PreArm: Mode requires mission" in texts
    # AUTOTUNE (15): not a mode of this build
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_DO_SET_MODE, 0,
                            mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 15, 0, 0, 0, 0, 0)
    result, texts = texts_until_ack(m, mav.MAV_CMD_DO_SET_MODE)
    assert result == mav.MAV_RESULT_FAILED and texts == ["No such mode 15"]
    # the gripper: none enabled
    assert command(m, mav.MAV_CMD_DO_GRIPPER, 1, 1) == mav.MAV_RESULT_FAILED
    # armed in GUIDED on the ground, a mission without a takeoff: AUTO refused in ArduCopter's words
    m.waypoint_clear_all_send()
    recv(m, "MISSION_ACK", 5)
    assert set_mode(m, "GUIDED") == mav.MAV_RESULT_ACCEPTED
    assert command(m, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert set_mode(m, "AUTO") == mav.MAV_RESULT_FAILED        # armed: no mission refused
    _upload_waypoint_only(m)
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_DO_SET_MODE, 0,
                            mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 3, 0, 0, 0, 0, 0)
    result, texts = texts_until_ack(m, mav.MAV_CMD_DO_SET_MODE)
    assert result == mav.MAV_RESULT_FAILED
    assert texts[-2:] == ["Auto: Missing Takeoff Cmd", "Mode change to AUTO failed: init failed"], texts


def _upload_waypoint_only(m) -> None:
    """Home and one waypoint 10 m up (no takeoff), by the mission protocol."""
    items = [(0, 0.0), (1, 10.0)]
    m.mav.mission_count_send(m.target_system, m.target_component, len(items), mav.MAV_MISSION_TYPE_MISSION)
    home = recv(m, "GLOBAL_POSITION_INT", 5)
    while True:
        req = recv(m, ["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], 5)
        if req.get_type() == "MISSION_ACK":
            assert req.type == mav.MAV_MISSION_ACCEPTED
            return
        seq, alt = items[req.seq]
        m.mav.mission_item_int_send(m.target_system, m.target_component, seq,
                                    mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_WAYPOINT, 0, 1,
                                    0, 0, 0, 0, home.lat, home.lon, alt, mav.MAV_MISSION_TYPE_MISSION)
