"""SET_ATTITUDE_TARGET decoding (vehicle/autopilot/attitude_target.py, pure) against ArduPilot's
handlers: ArduCopter's GCS_MAVLINK_Copter::handle_message_set_attitude_target (type_mask
combinations, unit quaternion, thrust as climb rate or as thrust per GUID_OPTIONS bit 3) and
ArduRover's GCS_MAVLINK_Rover::handle_set_attitude_target (speed from thrust, heading or
turn rate); and how GUIDED's attitude target moves at its body rates (guided_angle.py)."""
from __future__ import annotations

import math

import pytest

from common.frames import quaternion_from_euler
from vehicle.autopilot.attitude_target import (ATTITUDE_IGNORE, PITCH_RATE_IGNORE, RATES_IGNORE, ROLL_RATE_IGNORE,
                                               THROTTLE_IGNORE, YAW_RATE_IGNORE, AttitudeStop, climb_from_thrust,
                                               decode_copter, decode_rover)
from vehicle.autopilot.copter_modes.guided_angle import _advance
from vehicle.fleet import MAX_LEAN

UP, DN = 2.5, 1.5               # WPNAV_SPEED_UP / _DN defaults, m/s
RATES = (0.1, -0.2, 0.3)


def q_wxyz(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """MAVLink's quaternion order (w, x, y, z) of ZYX Euler angles."""
    x, y, z, w = quaternion_from_euler(roll, pitch, yaw)
    return (w, x, y, z)


Q20 = q_wxyz(math.radians(20), math.radians(-5), math.radians(90))


def copter(type_mask, q=Q20, rates=RATES, thrust=0.5, options=0):
    return decode_copter(type_mask, q, rates, thrust, options, UP, DN)


# ----------------------------------------------------------------------- copter: type_mask

def test_quaternion_without_rates_is_mavsdks_set_attitude():
    """MAVSDK's Offboard.set_attitude sends type_mask 7 (the three body rates ignored)."""
    t = copter(RATES_IGNORE)
    roll, pitch, yaw = t.attitude
    assert math.degrees(roll) == pytest.approx(20) and math.degrees(pitch) == pytest.approx(-5)
    assert math.degrees(yaw) == pytest.approx(90)
    assert t.rates == (0.0, 0.0, 0.0) and t.climb == 0.0 and t.thrust is None


def test_quaternion_with_all_rates_is_feed_forward():
    t = copter(0)
    assert t.attitude is not None and t.rates == RATES


def test_attitude_ignored_flies_the_body_rates_alone():
    """MAVSDK's set_attitude_rate: ATTITUDE_IGNORE, a zero quaternion, the three rates."""
    t = copter(ATTITUDE_IGNORE, q=(0.0, 0.0, 0.0, 0.0))
    assert t.attitude is None and t.rates == RATES
    t = copter(ATTITUDE_IGNORE | RATES_IGNORE, q=(0.0, 0.0, 0.0, 0.0))
    assert t.attitude is None and t.rates == (0.0, 0.0, 0.0)


@pytest.mark.parametrize("ignored", [ROLL_RATE_IGNORE, PITCH_RATE_IGNORE, YAW_RATE_IGNORE,
                                     ROLL_RATE_IGNORE | YAW_RATE_IGNORE, PITCH_RATE_IGNORE | YAW_RATE_IGNORE])
def test_some_rates_ignored_stops(ignored):
    with pytest.raises(AttitudeStop, match="partial body rate mask"):
        copter(ignored)
    with pytest.raises(AttitudeStop):
        copter(ignored | ATTITUDE_IGNORE)


def test_throttle_ignored_stops_without_a_reason():
    for mask in (THROTTLE_IGNORE, THROTTLE_IGNORE | RATES_IGNORE, THROTTLE_IGNORE | ATTITUDE_IGNORE):
        with pytest.raises(AttitudeStop) as e:
            copter(mask)
        assert str(e.value) == ""            # a valid request for the stop: nothing to say


@pytest.mark.parametrize("q", [(0.0, 0.0, 0.0, 0.0), (1.0, 0.1, 0.0, 0.0), (0.99, 0.0, 0.0, 0.0),
                               (float("nan"), 0.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0)])
def test_quaternion_not_unit_length_stops(q):
    with pytest.raises(AttitudeStop, match="not unit length"):
        copter(RATES_IGNORE, q=q)


def test_unit_length_within_1e3_is_taken():
    w, x, y, z = Q20
    k = 1.0004
    t = copter(RATES_IGNORE, q=(w * k, x * k, y * k, z * k))        # |q|^2 = 1.0008
    assert math.degrees(t.attitude[0]) == pytest.approx(20, abs=1e-6)


def test_non_finite_rates_or_thrust_stop():
    with pytest.raises(AttitudeStop, match="body rates not finite"):
        copter(0, rates=(0.0, float("inf"), 0.0))
    with pytest.raises(AttitudeStop, match="thrust not finite"):
        copter(RATES_IGNORE, thrust=float("nan"))
    copter(RATES_IGNORE, rates=(float("nan"),) * 3)                 # ignored rates are not read


# ----------------------------------------------------------------------- copter: thrust

@pytest.mark.parametrize("thrust, climb", [(0.5, 0.0), (1.0, UP), (0.75, UP / 2), (0.7, 0.4 * UP),
                                           (0.0, -DN), (0.25, -DN / 2), (1.5, UP), (-1.0, -DN)])
def test_thrust_is_a_climb_rate_by_default(thrust, climb):
    t = copter(RATES_IGNORE, thrust=thrust)
    assert t.thrust is None and t.climb == pytest.approx(climb)
    assert climb_from_thrust(thrust, UP, DN) == pytest.approx(climb)


def test_mavsdk_examples_thrust_climbs_at_one_metre_a_second():
    """Thrust 0.7 with WPNAV_SPEED_UP 250 cm/s: (0.7 - 0.5) * 2 * 2.5 = 1 m/s up."""
    assert copter(RATES_IGNORE, thrust=0.7).climb == pytest.approx(1.0)


@pytest.mark.parametrize("thrust, out", [(0.7, 0.7), (0.0, 0.0), (1.3, 1.0), (-0.4, -0.4), (-2.0, -1.0)])
def test_guid_options_bit_3_takes_thrust_as_thrust(thrust, out):
    for options in (8, 8 | 1 | 4, 255):
        t = copter(RATES_IGNORE, thrust=thrust, options=options)
        assert t.thrust == out and t.climb == 0.0
    assert copter(RATES_IGNORE, thrust=thrust, options=255 & ~8).thrust is None


# ----------------------------------------------------------------------- rover

def test_rover_heading_and_speed():
    t = decode_rover(RATES_IGNORE, Q20, 0.0, 0.5, 4.0)
    assert t.speed == 2.0 and math.degrees(t.heading) == pytest.approx(90) and t.yaw_rate is None


def test_rover_turn_rate_and_speed():
    t = decode_rover(ROLL_RATE_IGNORE | PITCH_RATE_IGNORE, Q20, 0.4, -0.25, 4.0)
    assert t.speed == -1.0 and t.heading is None and t.yaw_rate == 0.4


def test_rover_thrust_clamped_and_throttle_ignored_ignored():
    assert decode_rover(RATES_IGNORE, Q20, 0.0, 3.0, 4.0).speed == 4.0
    assert decode_rover(RATES_IGNORE, Q20, 0.0, -3.0, 4.0).speed == -4.0
    assert decode_rover(THROTTLE_IGNORE | RATES_IGNORE, Q20, 0.0, 0.5, 4.0) is None
    assert decode_rover(RATES_IGNORE, Q20, 0.0, float("nan"), 4.0) is None


def test_rover_reads_the_yaw_of_any_quaternion():
    """ArduRover does not check the quaternion: a zero one is north; roll and pitch do not matter."""
    assert decode_rover(RATES_IGNORE, (0.0, 0.0, 0.0, 0.0), 0.0, 0.5, 4.0).heading == 0.0
    tilted = q_wxyz(0.5, -0.3, math.radians(-120))
    assert math.degrees(decode_rover(RATES_IGNORE, tilted, 0.0, 0.5, 4.0).heading) == pytest.approx(-120)


# ----------------------------------------------------------------------- the target moving at its rates

def test_target_attitude_moves_at_its_body_rates():
    att = (0.0, 0.0, 0.0)
    for _ in range(100):                                   # 1 s of a 0.3 rad/s roll rate
        att = _advance(att, (0.3, 0.0, 0.0), 0.01)
    assert att[0] == pytest.approx(0.3) and att[1] == 0.0 and att[2] == 0.0
    # banked 30 deg, a body yaw rate turns the heading and pitches the nose (Euler rates)
    roll = math.radians(30)
    r = 0.2
    new = _advance((roll, 0.0, 0.0), (0.0, 0.0, r), 0.01)
    assert (new[2] - 0.0) / 0.01 == pytest.approx(r * math.cos(roll))
    assert (new[1] - 0.0) / 0.01 == pytest.approx(-r * math.sin(roll))


def test_target_attitude_stays_within_the_lean_the_controller_flies():
    att = (0.0, 0.0, 3.1)
    for _ in range(1000):
        att = _advance(att, (2.0, -2.0, 1.0), 0.01)
    assert abs(att[0]) <= MAX_LEAN and abs(att[1]) <= MAX_LEAN and -math.pi <= att[2] <= math.pi
    assert _advance((0.1, 0.2, 0.3), (0.0, 0.0, 0.0), 0.01) == (0.1, 0.2, 0.3)
