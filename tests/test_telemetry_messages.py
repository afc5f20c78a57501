"""ArduPilot's telemetry messages built from a stepped in-process world (no sockets): each
message carries what the simulation does -- the mixer's motor outputs, the trims, the
estimator's test ratios and flags (which change when GPS is lost or the estimate is wrong),
the IMU's noise, the position controller's targets and errors, the fence's breaches."""
from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from auto_world import Flight, airborne, goto
from vehicle.autopilot import modes
from vehicle.link.framing import Framer, layout
from vehicle.sim_faults import SimFaults
from vehicle.telemetry import version
from vehicle.telemetry.ekf_status import CONST_POS, HEALTHY_GPS, POS_ABS, VEL_HORIZ
from vehicle.telemetry.imu import dipole_field_ned, isa_pressure_pa

C = mav
NEW = ["RAW_IMU", "SCALED_IMU2", "SCALED_PRESSURE", "SERVO_OUTPUT_RAW", "RC_CHANNELS", "NAV_CONTROLLER_OUTPUT",
       "POSITION_TARGET_GLOBAL_INT", "EKF_STATUS_REPORT", "VIBRATION", "FENCE_STATUS", "POWER_STATUS", "MEMINFO",
       "AHRS", "AHRS2"]


def build(f: Flight, name: str):
    return f.v.link.telemetry.build(getattr(C, "MAVLINK_MSG_ID_" + name))


@pytest.mark.parametrize("kind", ["copter", "rover"])
def test_every_message_frames_as_pymavlink_parses_it(kind):
    f = Flight(kind, params={"FENCE_ENABLE": 1, "FENCE_TYPE": 2})
    f.settle()
    tel = f.v.link.telemetry
    parser = mav.MAVLink(None)
    names = NEW + (["RC_CHANNELS_SCALED"] if kind == "rover" else [])
    for name in names:
        msgid = getattr(C, "MAVLINK_MSG_ID_" + name)
        assert msgid in tel.builders, name
        values = tel.builders[msgid]()
        if values is None:         # nothing to say now: no destination, a rover outside AUTO
            assert name in ("POSITION_TARGET_GLOBAL_INT", "NAV_CONTROLLER_OUTPUT"), name
            continue
        built = layout(msgid).cls(*values)
        wire = Framer(f.v.link.mav).frame(msgid, values)
        got = parser.parse_char(wire)
        assert got is not None and got.get_type() == name
        for field in got.get_fieldnames():
            a, b = getattr(got, field), getattr(built, field)
            assert a == pytest.approx(b, rel=1e-6, abs=1e-5) if isinstance(a, float) else a == b, (name, field)


def test_servo_outputs_are_the_mixers_motor_commands():
    f = Flight("copter")
    f.settle()
    assert build(f, "SERVO_OUTPUT_RAW").servo1_raw == 1000        # disarmed: MOT_PWM_MIN
    airborne(f)
    s = build(f, "SERVO_OUTPUT_RAW")
    fr = f.ap.fleet.motor_outputs(0)
    outs = [s.servo1_raw, s.servo2_raw, s.servo3_raw, s.servo4_raw]
    assert outs == [round(1000 + 1000 * x) for x in fr]
    assert all(1500 < o < 1800 for o in outs), outs                 # hovering: about MOT_THST_HOVER
    assert s.servo5_raw == 0 and s.servo16_raw == 0
    f.ap.params.set("MOT_PWM_MIN", 1100, save=False)
    assert build(f, "SERVO_OUTPUT_RAW").servo1_raw == round(1100 + 900 * f.ap.fleet.motor_outputs(0)[0])
    # yawing right speeds up the counter-clockwise motors (1 front-right and 2 back-left)
    f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, 0b010111111000, [0, 0, -10], [0, 0, 0], [0, 0, 0], 0, 1.5)
    f.step(0.3)
    s = build(f, "SERVO_OUTPUT_RAW")
    assert s.servo1_raw + s.servo2_raw > s.servo3_raw + s.servo4_raw + 20


def test_rover_skid_steering_outputs_and_servo_out():
    f = Flight("rover")
    f.settle()
    assert [build(f, "SERVO_OUTPUT_RAW").servo1_raw, build(f, "SERVO_OUTPUT_RAW").servo3_raw] == [1500, 1500]
    assert f.ap.set_mode(modes.ROVER_GUIDED)
    assert f.ap.arm() == C.MAV_RESULT_ACCEPTED
    goto(f, 40, 0, 0)
    f.step(3.0)
    s = build(f, "SERVO_OUTPUT_RAW")
    assert s.servo1_raw > 1550 and s.servo3_raw > 1550                 # both sides drive forward
    scaled = build(f, "RC_CHANNELS_SCALED")
    assert scaled.chan1_scaled > 1000 and scaled.chan3_scaled > 1000 and scaled.chan2_scaled == 0
    nav = build(f, "NAV_CONTROLLER_OUTPUT")
    assert nav.target_bearing in (0, 359) and 20 < nav.wp_dist < 40 and nav.nav_roll == 0
    goto(f, f.ap.pos[0], 30, 0)                        # due east: a right turn in place
    f.step(0.3)
    s = build(f, "SERVO_OUTPUT_RAW")
    assert s.servo1_raw > 1500 > s.servo3_raw, (s.servo1_raw, s.servo3_raw)


@pytest.mark.parametrize("kind, throttle", [("copter", 1000), ("rover", 1500)])
def test_rc_channels_are_the_simulated_receivers(kind, throttle):
    """ArduPilot SITL's receiver (AP_RCProtocol_UDP::set_default_pwm_input_values): 8
    channels, channels 9-16 without a pulse read 0."""
    f = Flight(kind, params={"RC2_TRIM": 1520, "RC7_TRIM": 1100})
    f.settle()
    rc = build(f, "RC_CHANNELS")
    assert rc.chancount == 8 and rc.rssi == 255
    assert [getattr(rc, f"chan{n}_raw") for n in range(1, 9)] == [1500, 1500, throttle, 1500, 1800, 1000, 1000, 1800]
    assert [getattr(rc, f"chan{n}_raw") for n in range(9, 19)] == [0] * 10


def test_rc_channels_without_pulses_are_the_trims():
    f = Flight("copter", params={"SIM_RC_FAIL": 1, "RC2_TRIM": 1520, "RC7_TRIM": 1100})
    f.settle()
    rc = build(f, "RC_CHANNELS")
    assert rc.chancount == 16 and rc.rssi == 255
    assert [rc.chan1_raw, rc.chan2_raw, rc.chan3_raw, rc.chan7_raw, rc.chan16_raw] == [1500, 1520, 1500, 1100, 1500]
    assert rc.chan17_raw == 0 and rc.chan18_raw == 0


def test_ekf_status_is_the_estimators_and_degrades_without_gps():
    f = Flight("copter")
    f.settle()
    f.step(2.0)
    e = build(f, "EKF_STATUS_REPORT")
    assert e.flags == HEALTHY_GPS == 0x33F
    ratios = [e.velocity_variance, e.pos_horiz_variance, e.pos_vert_variance, e.compass_variance]
    assert all(0.0 < r < 1.0 for r in ratios), ratios
    est = f.ap.fleet.estimator
    seen = set()
    for _ in range(10):                    # the ratios follow each fusion's innovation
        f.step(0.1)
        seen.add(round(build(f, "EKF_STATUS_REPORT").pos_horiz_variance, 6))
    assert len(seen) > 5
    # starve the estimator of GPS (SIM_GPS1_ENABLE 0): dead reckoning, then timed out, then not aiding
    f.ap.fleet.set_faults(f.ap.i, SimFaults(gps_enabled=False))
    f.step(6.0)
    assert build(f, "EKF_STATUS_REPORT").flags == HEALTHY_GPS
    f.step(2.0)
    e = build(f, "EKF_STATUS_REPORT")
    assert not e.flags & (POS_ABS | VEL_HORIZ) and not e.flags & CONST_POS and e.flags & C.EKF_ATTITUDE
    f.step(8.0)
    e = build(f, "EKF_STATUS_REPORT")
    assert e.flags & CONST_POS and not e.flags & POS_ABS and est.no_aiding.active[f.ap.i]
    # EKF3 resets both when aiding stops; then fuses the last known position, not a velocity
    assert e.velocity_variance == 0.0 and 0.0 < e.pos_horiz_variance < 0.5
    f.ap.fleet.set_faults(f.ap.i, SimFaults())
    f.step(0.3)
    assert build(f, "EKF_STATUS_REPORT").flags == HEALTHY_GPS


def test_ekf_position_variance_rises_when_the_estimate_is_wrong():
    f = Flight("copter")
    f.settle()
    f.step(1.0)
    assert build(f, "EKF_STATUS_REPORT").pos_horiz_variance < 1.0
    est = f.ap.fleet.estimator
    est.kfs[0].x[0] += 25.0                 # the estimate jumps 25 m north of the truth
    f.step(0.12)                            # the next GPS fix disagrees
    e = build(f, "EKF_STATUS_REPORT")
    assert e.pos_horiz_variance > 1.0 and e.velocity_variance < 1.0, e


def test_vibration_and_raw_sensors_come_from_the_imu_model():
    f = Flight("copter")
    f.settle()
    v = build(f, "VIBRATION")
    sigma = f.ap.fleet.spec.accel_sigma
    assert (v.vibration_x, v.vibration_y, v.vibration_z) == (sigma, sigma, sigma) and v.clipping_0 == 0
    zs = []
    for _ in range(50):
        zs.append(build(f, "RAW_IMU").zacc)
        assert build(f, "RAW_IMU").zacc == zs[-1]          # one reading per instant
        f.step(0.02)
    assert -1020 < np.mean(zs) < -980 and np.std(zs) > 2                # 1 g up, with noise (milli-g)
    imu2 = build(f, "SCALED_IMU2")
    bn, _, bd = dipole_field_ned(f.origin[0])
    assert abs(imu2.xmag - bn) < 15 and abs(imu2.zmag - bd) < 15 and abs(imu2.zacc + 1000) < 40

    def pressure() -> float:
        p = []
        for _ in range(20):
            p.append(build(f, "SCALED_PRESSURE").press_abs)
            f.step(0.02)
        return float(np.mean(p))
    p0 = pressure()
    assert p0 == pytest.approx(isa_pressure_pa(f.origin[2]) / 100.0, abs=0.1)
    airborne(f, 20.0)
    p1 = pressure()
    assert 2.0 < p0 - p1 < 2.6                     # ~0.12 hPa per metre up
    ahrs = build(f, "AHRS")
    assert 0 < ahrs.error_rp < 0.05 and ahrs.omegaIx == 0.0
    a2 = build(f, "AHRS2")
    assert a2.altitude == pytest.approx(f.ap.lla()[2], abs=0.5) and a2.yaw == pytest.approx(f.ap.yaw, abs=1e-6)


def test_nav_controller_output_follows_the_position_controller():
    f = Flight("copter")
    airborne(f)
    assert goto(f, 60, 0, f.ap.home[2] - 10)
    f.step(0.8)
    n = build(f, "NAV_CONTROLLER_OUTPUT")
    assert n.target_bearing in (0, 359) and 50 < n.wp_dist <= 60
    assert n.nav_pitch < -5.0 and abs(n.nav_roll) < 3.0           # nose down to accelerate north
    assert abs(n.nav_bearing) <= 1 and abs(n.alt_error) < 0.5 and n.xtrack_error < 1.0
    t = build(f, "POSITION_TARGET_GLOBAL_INT")
    lat, lon, alt = f.ap.lla(np.asarray(f.ap.fleet.setpoint(0).pos))      # the goal, local NED from the EKF origin
    assert (t.lat_int, t.lon_int) == (round(lat * 1e7), round(lon * 1e7)) and t.alt == pytest.approx(alt, abs=0.01)
    assert t.coordinate_frame == C.MAV_FRAME_GLOBAL and t.type_mask & C.POSITION_TARGET_TYPEMASK_VX_IGNORE
    f.until(lambda: build(f, "NAV_CONTROLLER_OUTPUT").wp_dist < 1, 40, "arrival")
    # a climb: the shaped altitude target moves up and the controller keeps up with it
    assert goto(f, 60, 0, f.ap.home[2] - 30)
    errors = []
    for _ in range(20):
        f.step(0.1)
        errors.append(build(f, "NAV_CONTROLLER_OUTPUT").alt_error)
    assert max(abs(e) for e in errors) < 0.3 and len(set(errors)) > 10
    # ALT_HOLD navigates nowhere: no destination, no target message
    assert f.ap.set_mode(modes.ALT_HOLD)
    f.step(0.2)
    n = build(f, "NAV_CONTROLLER_OUTPUT")
    assert n.wp_dist == 0 and n.target_bearing == 0 and build(f, "POSITION_TARGET_GLOBAL_INT") is None


def test_fence_status_counts_breaches():
    f = Flight("copter", params={"FENCE_ENABLE": 0, "FENCE_TYPE": 2, "FENCE_RADIUS": 30, "FENCE_ACTION": 0})
    f.settle()
    assert build(f, "FENCE_STATUS") is None                       # sent only while enabled
    f.ap.params.set("FENCE_ENABLE", 1, save=False)
    s = build(f, "FENCE_STATUS")
    assert (s.breach_status, s.breach_count, s.breach_type) == (0, 0, C.FENCE_BREACH_NONE)
    airborne(f)

    def fly_north() -> bool:           # a velocity target times out: send it again, as a GCS does
        f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, 0b110111000111, [0, 0, 0], [5, 0, 0], [0, 0, 0], 0, 0)
        return build(f, "FENCE_STATUS").breach_status == 1
    f.until(fly_north, 30, "breach")
    s = build(f, "FENCE_STATUS")
    assert s.breach_count == 1 and s.breach_type == C.FENCE_BREACH_BOUNDARY
    assert abs(s.breach_time - f.world.t * 1000) < 200 and s.breach_mitigation == C.FENCE_MITIGATE_NONE


def test_board_messages():
    f = Flight("rover")
    f.settle()
    p, m = build(f, "POWER_STATUS"), build(f, "MEMINFO")
    assert p.Vcc == 5000 and p.flags & C.MAV_POWER_STATUS_BRICK_VALID
    assert (m.freemem, m.freemem32) == (65535, 131072)


def test_version_hash_and_banner():
    h = version.build_hash()
    assert len(h) == 8 and all(c in "0123456789abcdef" for c in h)
    assert bytes(version.custom_version_bytes()).decode() == h
    assert version.banner("copter", 1) == [f"ArduCopter V4.5.0 ({h})", "towerlink SITL 1", "Frame: QUAD/X"]
    assert version.banner("rover", 2)[0] == f"ArduRover V4.5.0 ({h})"
    f = Flight("copter")
    av = f.v.link.telemetry.autopilot_version()
    assert bytes(av.flight_custom_version).decode() == h
    assert av.flight_sw_version >> 24 == 4 and (av.flight_sw_version >> 16) & 0xFF == 5
