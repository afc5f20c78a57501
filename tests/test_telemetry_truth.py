"""The rest of ArduPilot's telemetry set, built from a stepped in-process world (no sockets):
SIMSTATE / SIM_STATE against the physics' truth, WIND against the world's wind model, SITL's
third compass and second barometer, PID_TUNING from the rate controllers (GCS_PID_MASK) and
ATTITUDE_TARGET from the attitude controller; and the stream groups that carry them."""
from __future__ import annotations

import math

import numpy as np
import pytest
from auto_world import Flight, airborne, goto
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from common.frames import euler_from_quaternion
from vehicle.physics.wind import WIND_TYPE_NO_LIMIT, WindParams
from vehicle.telemetry.stream_groups import stream_groups
from vehicle.telemetry.truth import wind_fields_of

C = mav


def build(f: Flight, name: str):
    return f.v.link.telemetry.build(getattr(C, "MAVLINK_MSG_ID_" + name))


def build_all(f: Flight, name: str):
    return f.v.link.telemetry.build_all(getattr(C, "MAVLINK_MSG_ID_" + name))


def test_simstate_and_sim_state_are_the_physics_truth():
    f = Flight("copter")
    f.settle()
    s = build(f, "SIMSTATE")
    assert s.zacc == pytest.approx(-9.80665, abs=0.05) and abs(s.xacc) < 0.05     # at rest: 1 g up
    airborne(f, 15.0)
    assert goto(f, 40, 10, f.ap.home[2] - 15)
    f.step(1.5)                                       # accelerating: leaning, turning
    row = f.ap.fleet.truth_row(0)
    s, s2 = build(f, "SIMSTATE"), build(f, "SIM_STATE")
    r, p, y = euler_from_quaternion(row[6:10])
    assert (s.roll, s.pitch, s.yaw) == pytest.approx((r, p, y), abs=1e-6) and abs(p) > 0.05
    assert (s.xgyro, s.ygyro, s.zgyro) == pytest.approx(tuple(row[10:13]), abs=1e-6)
    lat, lon, alt = geo.ned_to_lla(f.ap.origin, row[0:3])
    assert (s.lat, s.lng) == (round(lat * 1e7), round(lon * 1e7))
    assert s2.alt == pytest.approx(alt, abs=1e-3) and (s2.vn, s2.ve, s2.vd) == pytest.approx(tuple(row[3:6]))
    assert (s2.xacc, s2.yacc, s2.zacc) == pytest.approx((s.xacc, s.yacc, s.zacc))
    # the accelerometer's truth: body specific force, whose world form is acceleration - gravity
    q = row[6:10]
    world = geo_rotate(q, (s.xacc, s.yacc, s.zacc))
    assert world == pytest.approx((row[13], row[14], row[15] - 9.80665), abs=1e-3)
    assert s.zacc < -5.0                                # thrust: along the body -z axis


def geo_rotate(q, v):
    """v (body) in the world frame: R(q) v, q = (x, y, z, w) body -> world."""
    x, y, z, w = q
    m = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return tuple(m @ np.asarray(v))


def test_wind_is_the_world_wind_model_in_ardupilots_form():
    assert wind_fields_of((0.0, 5.0, 0.0)) == pytest.approx((-90.0, 5.0, 0.0))   # a westerly moves air east
    assert wind_fields_of((-3.0, 0.0, -1.0))[0] == pytest.approx(0.0)             # from the north, rising
    f = Flight("copter")
    f.settle()
    assert build(f, "WIND").speed == 0.0                                          # still air
    f.world.set_wind(WindParams(speed=6.0, direction=270.0, type=WIND_TYPE_NO_LIMIT))
    airborne(f, 10.0)
    f.step(1.0)
    w = build(f, "WIND")
    assert w.direction == pytest.approx(-90.0, abs=0.5) and w.speed == pytest.approx(6.0, abs=0.05)
    air = f.ap.fleet.air[0]
    assert w.speed_z == pytest.approx(float(air[2]), abs=1e-6)
    r = Flight("rover")
    r.settle()
    assert build(r, "WIND") is None                     # ArduRover: a wind vane only


def test_third_compass_and_second_barometer_as_sitl_has_them():
    f = Flight("copter")
    f.settle()
    i2, i3 = build(f, "SCALED_IMU2"), build(f, "SCALED_IMU3")
    assert (i3.xacc, i3.yacc, i3.zacc, i3.xgyro, i3.temperature) == (0, 0, 0, 0, 0)
    assert (i3.xmag, i3.ymag, i3.zmag) == (i2.xmag, i2.ymag, i2.zmag) and abs(i3.zmag) > 100
    p1, p2 = [], []
    for _ in range(30):
        p1.append(build(f, "SCALED_PRESSURE").press_abs)
        p2.append(build(f, "SCALED_PRESSURE2").press_abs)
        assert build(f, "SCALED_PRESSURE2").press_abs == p2[-1]     # one reading per instant
        f.step(0.02)
    assert np.mean(p2) == pytest.approx(np.mean(p1), abs=0.05) and p1 != p2    # own noise
    assert build(f, "SCALED_PRESSURE3") is None                         # SIM_BARO_COUNT 2


def test_pid_tuning_follows_gcs_pid_mask_and_the_rate_controllers():
    f = Flight("copter")
    airborne(f)
    assert build(f, "PID_TUNING") is None                               # GCS_PID_MASK 0
    f.ap.params.set("GCS_PID_MASK", 4, save=False)                      # yaw
    f.ap.position_target_local(C.MAV_FRAME_LOCAL_NED, 0b010111111000, [0, 0, -10], [0, 0, 0], [0, 0, 0], 0, 1.0)
    f.step(0.5)
    p = build(f, "PID_TUNING")
    c = f.ap.fleet.controller_of(0)
    kp = f.ap.fleet.gains_of(0).rat[2][0]
    assert p.axis == C.PID_TUNING_YAW and p.desired == pytest.approx(c.rtz) and p.desired > 0.5
    assert p.achieved == pytest.approx(c.rtz - c.erz) and p.P == pytest.approx(kp * c.erz)
    assert p.I == pytest.approx(c.irz) and p.PDmod == 1.0
    assert abs(p.achieved - f.ap.rates[2]) < 0.2                       # the estimated yaw rate
    f.ap.params.set("GCS_PID_MASK", 15, save=False)
    for _ in range(3):                  # every enabled axis each time, in ArduPilot's order
        f.step(0.02)
        assert [p.axis for p in build_all(f, "PID_TUNING")] == [1, 2, 3, 4]
    f.ap.params.set("GCS_PID_MASK", 10, save=False)                     # pitch and accel z
    _pitch, a = build_all(f, "PID_TUNING")
    assert (_pitch.axis, a.axis) == (C.PID_TUNING_PITCH, C.PID_TUNING_ACCZ)
    assert abs(a.desired) < 100 and abs(a.achieved) < 100 and a.FF == a.desired     # hovering, cm/s^2

def test_rover_pid_tuning_is_its_steering_and_speed_commands():
    from vehicle.autopilot import modes
    r = Flight("rover", params={"GCS_PID_MASK": 1})
    r.settle()
    assert r.ap.set_mode(modes.ROVER_GUIDED) and r.ap.arm() == C.MAV_RESULT_ACCEPTED
    goto(r, 0, 30, 0)                                   # due east: a right turn
    r.step(0.3)
    p = build(r, "PID_TUNING")
    assert p.axis == C.PID_TUNING_STEER and p.desired > 20                 # deg/s, turning right
    assert p.achieved == pytest.approx(math.degrees(r.ap.fleet.drive_outputs(0)[2])) and p.FF == p.desired
    r.ap.params.set("GCS_PID_MASK", 2, save=False)
    r.step(3.0)
    p = build(r, "PID_TUNING")
    v_cmd, speed, _ = r.ap.fleet.drive_outputs(0)
    assert p.axis == C.PID_TUNING_ACCZ and (p.desired, p.achieved) == pytest.approx((v_cmd, speed)) and speed > 0.5


def test_esc_telemetry_is_each_motors_speed_and_the_pack():
    f = Flight("copter", params={"BATT_MONITOR": 4})
    f.settle()
    assert f.world.t < 6.0 and build(f, "ESC_TELEMETRY_1_TO_4") is None        # SITL: nothing at first
    airborne(f)
    e = build(f, "ESC_TELEMETRY_1_TO_4")
    w_max = f.ap.fleet.airframe.omega_max
    assert e.rpm == [round(x * w_max * 60 / (2 * math.pi)) for x in f.ap.fleet.motor_outputs(0)]
    assert all(3000 < r < 11000 for r in e.rpm), e.rpm                          # hovering
    b = f.ap.battery.reading(f.ap.params.values)
    assert e.voltage == [round(b.voltage * 100)] * 4 and e.current == [round(b.current * 25)] * 4
    assert e.count[0] == int(f.world.t * 50) & 0xFFFF and e.temperature == [0] * 4
    assert build(Flight("rover"), "ESC_TELEMETRY_1_TO_4") is None


def test_attitude_target_is_the_attitude_controllers():
    f = Flight("copter")
    airborne(f)
    t = build(f, "ATTITUDE_TARGET")
    q = f.ap.quat.tolist()                                             # x, y, z, w
    assert abs(abs(float(np.dot(q, [t.q[1], t.q[2], t.q[3], t.q[0]]))) - 1.0) < 1e-3   # holding attitude
    assert t.type_mask == 0 and 0.3 < t.thrust < 0.8
    assert goto(f, 60, 0, f.ap.home[2] - 10)
    f.step(0.8)
    t = build(f, "ATTITUDE_TARGET")
    _, pitch, _ = euler_from_quaternion((t.q[1], t.q[2], t.q[3], t.q[0]))
    assert math.degrees(pitch) == pytest.approx(build(f, "NAV_CONTROLLER_OUTPUT").nav_pitch, abs=0.5)
    assert math.degrees(pitch) < -5                                    # nose down to go north
    r = Flight("rover")
    assert build(r, "ATTITUDE_TARGET") is None


def test_stream_groups_carry_the_new_messages_where_ardupilot_does():
    for kind in ("copter", "rover"):
        g = stream_groups(kind)
        assert {C.MAVLINK_MSG_ID_SCALED_IMU3, C.MAVLINK_MSG_ID_SCALED_PRESSURE2,
                C.MAVLINK_MSG_ID_SCALED_PRESSURE3} <= set(g["SR0_RAW_SENS"])
        assert {C.MAVLINK_MSG_ID_SIMSTATE, C.MAVLINK_MSG_ID_PID_TUNING,
                C.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4} <= set(g["SR0_EXTRA1"])
        assert C.MAVLINK_MSG_ID_WIND in g["SR0_EXTRA3"]
        assert all(C.MAVLINK_MSG_ID_ATTITUDE_TARGET not in ids for ids in g.values())    # on request only
