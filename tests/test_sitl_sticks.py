"""A pilot's sticks over loopback with pymavlink, as a script flies ArduPilot with
RC_CHANNELS_OVERRIDE (MAVProxy's `rc`) and MANUAL_CONTROL (QGroundControl's virtual joystick):
overrides only from SYSID_MYGCS, RC_CHANNELS and SERVO_OUTPUT_RAW showing them, arming refused
with the throttle up, ALT_HOLD's pilot takeoff, climb and hold on release, POSHOLD moved by the
pitch stick and braking to a hold, LOITER flown by MANUAL_CONTROL, lost overrides going back to
the simulated receiver's sticks (no failsafe), the radio failsafe on lost receiver pulses and its
clearing, a rover driven in MANUAL. Times are the vehicle's (time_boot_ms)."""
from __future__ import annotations

import math
import time

import pytest

from support import Processes
from test_sitl_support import Sitl, command, connect, mav, recv, set_mode, set_param, wait_armable

KEEP = 65535
CENTRE = (1500, 1500, 1500, 1500)
SEND_EVERY = 0.05          # wall s between overrides (a GCS sends 10-50 Hz)


class Pilot:
    """The sticks of one connection: `hold(chans_or_axes, types, cond, timeout)` keeps sending
    them (RC_CHANNELS_OVERRIDE, or MANUAL_CONTROL when given x, y, z, r) until a message of
    `types` satisfies cond."""

    def __init__(self, m) -> None:
        self.m = m

    def send(self, sticks) -> None:
        m = self.m
        if isinstance(sticks, dict):
            m.mav.manual_control_send(m.target_system, sticks.get("x", 0), sticks.get("y", 0),
                                      sticks.get("z", 500), sticks.get("r", 0), 0)
        else:
            chans = list(sticks) + [KEEP] * (8 - len(sticks)) + [0] * 10
            m.mav.rc_channels_override_send(m.target_system, m.target_component, *chans)

    def hold(self, sticks, types, cond, timeout=20.0):
        deadline = time.monotonic() + timeout
        while True:
            self.send(sticks)
            try:
                return recv(self.m, types, SEND_EVERY, cond=cond)
            except AssertionError:
                if time.monotonic() > deadline:
                    raise AssertionError(f"{types} never satisfied the condition within {timeout} s")

    def hold_for(self, sticks, sim_s, timeout=20.0):
        """Keep the sticks for sim_s of the vehicle's time; the LOCAL_POSITION_NED seen then."""
        first = self.hold(sticks, "LOCAL_POSITION_NED", None, timeout)
        end = first.time_boot_ms + sim_s * 1000
        return self.hold(sticks, "LOCAL_POSITION_NED", lambda p: p.time_boot_ms >= end, timeout)


def _interval(m, msgid, hz=10):
    assert command(m, mav.MAV_CMD_SET_MESSAGE_INTERVAL, msgid, 1e6 / hz) == mav.MAV_RESULT_ACCEPTED


def _text(m, text, timeout=10.0, pilot=None, sticks=None):
    if pilot is None:
        return recv(m, "STATUSTEXT", timeout, cond=lambda s: s.text == text)
    return pilot.hold(sticks, "STATUSTEXT", lambda s: s.text == text, timeout)


def _arm(m):
    """Arm: (COMMAND_ACK result, the STATUSTEXTs said before it)."""
    texts = []
    m.mav.command_long_send(m.target_system, m.target_component, mav.MAV_CMD_COMPONENT_ARM_DISARM,
                            0, 1, 0, 0, 0, 0, 0, 0)

    def ack(msg):
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
            return False
        return msg.command == mav.MAV_CMD_COMPONENT_ARM_DISARM
    return recv(m, ["COMMAND_ACK", "STATUSTEXT"], 5, cond=ack).result, texts


def _drift_after_stop(pilot, sticks) -> tuple[float, float]:
    """Hold `sticks` until the copter stops, then 3 s more: (horizontal, vertical) m moved."""
    pilot.hold(sticks, "LOCAL_POSITION_NED", lambda p: math.hypot(p.vx, p.vy) < 0.1, 30)
    p0 = recv(pilot.m, "LOCAL_POSITION_NED", 5)
    p1 = pilot.hold_for(sticks, 3.0)
    return math.hypot(p1.x - p0.x, p1.y - p0.y), abs(p1.z - p0.z)


def _flying_in(sitl, mode):
    """The drone switched to `mode`: (connection, its Pilot, the ATTITUDE then)."""
    drone = sitl[1]
    assert set_mode(drone, mode) == mav.MAV_RESULT_ACCEPTED
    return drone, Pilot(drone), recv(drone, "ATTITUDE", 5)


def _forward(p, att) -> float:
    return p.vx * math.cos(att.yaw) + p.vy * math.sin(att.yaw)


@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    procs = Processes()
    try:
        s = Sitl(procs, tmp_path_factory.mktemp("sticks"), drones=1, rovers=1, speedup=3)
        drone, rover = connect(s.udp[0]), connect(s.udp[1])
        for m in (drone, rover):
            _interval(m, mav.MAVLINK_MSG_ID_RC_CHANNELS)
            _interval(m, mav.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW)
        yield s, drone, rover
    finally:
        procs.stop_all()


@pytest.mark.timeout(60)
def test_overrides_only_from_sysid_mygcs_and_rc_channels_shows_them(sitl):
    s, drone, _ = sitl
    other = connect(s.udp[0], sysid=200)
    try:
        for _ in range(10):
            other.mav.rc_channels_override_send(1, 1, 1500, 1500, 1900, 1500, *[KEEP] * 4, *[0] * 10)
        rc = recv(drone, "RC_CHANNELS", 5)
        assert rc.chan3_raw == 1000 and rc.chancount == 8                # still the receiver's
        rc = Pilot(drone).hold((1500, 1500, 1234, 1500, KEEP, 1700), "RC_CHANNELS",
                               lambda r: r.chan3_raw == 1234, 10)
        assert rc.chan6_raw == 1700 and rc.chan7_raw == 1000 and rc.chan16_raw == 0   # the receiver's
    finally:
        other.close()


@pytest.mark.timeout(60)
def test_arming_refused_with_the_throttle_up(sitl):
    _, drone, _ = sitl
    pilot = Pilot(drone)
    wait_armable(drone, 30)
    assert set_mode(drone, "STABILIZE") == mav.MAV_RESULT_ACCEPTED
    pilot.hold((1500, 1500, 1300, 1500), "RC_CHANNELS", lambda r: r.chan3_raw == 1300)
    assert _arm(drone) == (mav.MAV_RESULT_FAILED, ["Arm: Throttle too high"])
    pilot.hold((1500, 1500, 1000, 1500), "RC_CHANNELS", lambda r: r.chan3_raw == 1000)
    assert command(drone, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    assert command(drone, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0) == mav.MAV_RESULT_ACCEPTED


@pytest.mark.timeout(120)
def test_alt_hold_pilot_takeoff_climb_and_hold_on_release(sitl):
    _, drone, _ = sitl
    pilot = Pilot(drone)
    set_param(drone, "FS_THR_ENABLE", 0)          # a loaded machine's pause in the sending is no failsafe here
    assert set_mode(drone, "ALT_HOLD") == mav.MAV_RESULT_ACCEPTED
    pilot.hold(CENTRE, "RC_CHANNELS", lambda r: r.chan3_raw == 1500)
    assert command(drone, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    up = pilot.hold((1500, 1500, 1900, 1500), "LOCAL_POSITION_NED", lambda p: p.z < -6.0, 60)
    assert up.vz < -1.0                                                 # climbing on the stick
    servo = recv(drone, "SERVO_OUTPUT_RAW", 5)
    assert all(1100 < getattr(servo, f"servo{k}_raw") < 2000 for k in range(1, 5))
    pilot.hold(CENTRE, "LOCAL_POSITION_NED", lambda p: abs(p.vz) < 0.1, 30)
    z0 = recv(drone, "LOCAL_POSITION_NED", 5).z
    end = pilot.hold_for(CENTRE, 3.0)
    assert abs(end.z - z0) < 0.3 and abs(end.vz) < 0.2                 # released: holds the altitude


@pytest.mark.timeout(120)
def test_poshold_pitch_stick_moves_forward_then_brakes_to_a_hold(sitl):
    drone, pilot, att = _flying_in(sitl, "POSHOLD")
    fwd = pilot.hold((1500, 1250, 1500, 1500), "LOCAL_POSITION_NED", lambda p: _forward(p, att) > 3.0, 30)
    assert abs(fwd.vx * math.sin(att.yaw) - fwd.vy * math.cos(att.yaw)) < 1.0   # no sideways drift
    assert _drift_after_stop(pilot, CENTRE)[0] < 0.5


@pytest.mark.timeout(120)
def test_loiter_flown_by_manual_control(sitl):
    drone, pilot, att = _flying_in(sitl, "LOITER")
    stick = {"x": 800, "y": 0, "z": 500, "r": 0}                       # forward, throttle mid
    pilot.hold(stick, "LOCAL_POSITION_NED", lambda p: _forward(p, att) > 4.0, 30)
    rc = pilot.hold(stick, "RC_CHANNELS", None)
    assert rc.chan2_raw < 1200 and rc.chan1_raw == 1500                # pitch forward is low PWM
    still = {"x": 0, "y": 0, "z": 500, "r": 0}
    horizontal, vertical = _drift_after_stop(pilot, still)
    assert horizontal < 0.5 and vertical < 0.3
    yawing = {"x": 0, "y": 0, "z": 500, "r": 600}
    yaw0 = att.yaw
    a = pilot.hold(yawing, "ATTITUDE", lambda a: a.yawspeed > 1.0, 20)    # yaw stick right: turns right
    assert a.yaw != yaw0


@pytest.mark.timeout(120)
def test_lost_overrides_go_back_to_the_receiver_and_lost_pulses_are_the_radio_failsafe(sitl):
    _, drone, _ = sitl
    pilot = Pilot(drone)
    assert set_mode(drone, "ALT_HOLD") == mav.MAV_RESULT_ACCEPTED
    pilot.hold((1500, 1500, 1900, 1500), "LOCAL_POSITION_NED", lambda p: p.z < -10.0, 60)
    pilot.hold_for(CENTRE, 0.5)
    set_param(drone, "FS_THR_ENABLE", 1)
    # the overrides stop (heartbeats go on): RC_OVERRIDE_TIME (3 s) later the receiver's sticks
    # again, throttle 1000: ALT_HOLD descends, no radio failsafe (the receiver's frames go on)
    texts, seen = [], {}
    while not ("rc" in seen and "down" in seen):
        msg = recv(drone, ["STATUSTEXT", "RC_CHANNELS", "LOCAL_POSITION_NED", "HEARTBEAT"], 20)
        kind = msg.get_type()
        if kind == "STATUSTEXT":
            texts.append(msg.text)
        elif kind == "RC_CHANNELS" and msg.chan3_raw == 1000:
            seen["rc"] = msg
        elif kind == "LOCAL_POSITION_NED" and "rc" in seen and msg.vz > 1.0:
            seen["down"] = msg
        elif kind == "HEARTBEAT" and msg.get_srcSystem() == drone.target_system:
            assert msg.custom_mode == 2, msg                             # still ALT_HOLD
    assert not any(t.startswith("Radio Failsafe") for t in texts), texts
    assert seen["rc"].chancount == 8 and seen["rc"].chan1_raw == 1500
    pilot.hold(CENTRE, "LOCAL_POSITION_NED", lambda p: abs(p.vz) < 0.3, 30)
    # the receiver goes silent (SIM_RC_FAIL 1): RC_FS_TIMEOUT (1 s) later the radio failsafe, RTL
    set_param(drone, "SIM_RC_FAIL", 1)
    _text(drone, "Radio Failsafe", 20)
    recv(drone, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 6 and h.system_status == mav.MAV_STATE_CRITICAL)
    set_param(drone, "SIM_RC_FAIL", 0)
    _text(drone, "Radio Failsafe Cleared", 10)
    recv(drone, "HEARTBEAT", 5, cond=lambda h: h.custom_mode == 6 and h.system_status == mav.MAV_STATE_ACTIVE)


@pytest.mark.timeout(90)
def test_rover_manual_drives_on_the_sticks(sitl):
    _, _, rover = sitl
    pilot = Pilot(rover)
    set_param(rover, "FS_THR_ENABLE", 0)
    wait_armable(rover, 30)
    assert set_mode(rover, "MANUAL") == mav.MAV_RESULT_ACCEPTED
    pilot.hold(CENTRE, "RC_CHANNELS", lambda r: r.chan3_raw == 1500)
    assert command(rover, mav.MAV_CMD_COMPONENT_ARM_DISARM, 1) == mav.MAV_RESULT_ACCEPTED
    pilot.hold((1500, 1500, 1800, 1500), "VFR_HUD", lambda v: v.groundspeed > 6.0, 30)
    servo = pilot.hold((1500, 1500, 1800, 1500), "SERVO_OUTPUT_RAW", None)
    assert servo.servo1_raw > 1600 and servo.servo3_raw > 1600         # both sides forward
    turn = pilot.hold((1800, 1500, 1800, 1500), "SERVO_OUTPUT_RAW", lambda o: o.servo1_raw - o.servo3_raw > 100)
    assert turn.servo1_raw > turn.servo3_raw                           # right turn: left side faster
    pilot.hold(CENTRE, "VFR_HUD", lambda v: v.groundspeed < 0.2, 30)
