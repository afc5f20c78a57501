"""SET_ATTITUDE_TARGET decoding as ArduCopter's and ArduRover's GUIDED read it (pure, no I/O).

ArduCopter (GCS_MAVLink_Copter.cpp handle_message_set_attitude_target):
  THROTTLE_IGNORE set -> no target: GUIDED stops and holds (ModeGuided::init(true)).
  ATTITUDE_IGNORE clear -> q (w, x, y, z) is the target attitude; it must be unit length
  within 1e-3 (Quaternion::is_unit_length), else GUIDED stops. ATTITUDE_IGNORE set -> body
  rates only.
  The three BODY_*_RATE_IGNORE bits: all clear -> the body rates are used (with a quaternion
  as its feed-forward, without one as the target); all set -> zero rates; a mix -> stop.
  thrust: a climb rate unless GUID_OPTIONS bit 3 (SetAttitudeTarget_ThrustAsThrust): clamped
  to 0..1, 0.5 holds altitude, above it climbs at up to WPNAV_SPEED_UP, below it descends at
  up to WPNAV_SPEED_DN (thrust 1 = +WPNAV_SPEED_UP, 0 = -WPNAV_SPEED_DN). With the option,
  thrust (clamped to -1..1) is the throttle.
  ArduCopter says nothing when it stops; towerlink says why a target it cannot fly was
  refused (a STATUSTEXT, as it does for position targets), but not for THROTTLE_IGNORE,
  which is a valid way to ask for the stop. NaN or infinite rates or thrust are refused too.

ArduRover (GCS_MAVLink_Rover.cpp handle_set_attitude_target):
  THROTTLE_IGNORE set -> ignored. thrust (clamped to -1..1) times the mode's default speed
  (WP_SPEED, or CRUISE_SPEED when WP_SPEED is 0) is the target speed. BODY_YAW_RATE_IGNORE
  set -> drive on the quaternion's heading; clear -> turn at body_yaw_rate. Roll and pitch
  are ignored.

Angles are rad (roll, pitch, yaw: ZYX Euler, R = Rz(yaw) Ry(pitch) Rx(roll), body FRD to
NED), rates rad/s, climb rates m/s up, speeds m/s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames import euler_from_quaternion

ROLL_RATE_IGNORE = mav.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE
PITCH_RATE_IGNORE = mav.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE
YAW_RATE_IGNORE = mav.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE
RATES_IGNORE = ROLL_RATE_IGNORE | PITCH_RATE_IGNORE | YAW_RATE_IGNORE
THROTTLE_IGNORE = mav.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE
ATTITUDE_IGNORE = mav.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
THRUST_AS_THRUST = 8          # GUID_OPTIONS bit 3 (ModeGuided::Option::SetAttitudeTarget_ThrustAsThrust)
UNIT_TOLERANCE = 1e-3         # Quaternion::is_unit_length


class AttitudeStop(ValueError):
    """ArduCopter's answer is GUIDED's stop; str() is the reason to say ('' for none)."""


@dataclass(frozen=True)
class AttitudeTarget:
    """What a copter's GUIDED flies from one SET_ATTITUDE_TARGET.

    attitude: (roll, pitch, yaw) rad, or None when the body rates alone are the target.
    rates: body (roll, pitch, yaw) rates, rad/s (feed-forward with an attitude).
    climb: m/s up (used when thrust is None). thrust: -1..1 throttle (GUID_OPTIONS bit 3)."""
    attitude: tuple[float, float, float] | None
    rates: tuple[float, float, float]
    climb: float
    thrust: float | None


@dataclass(frozen=True)
class RoverAttitudeTarget:
    """What a rover's GUIDED drives from one SET_ATTITUDE_TARGET: speed (m/s, negative =
    backwards) on heading (rad from north), or turning at yaw_rate (rad/s) when heading is None."""
    speed: float
    heading: float | None
    yaw_rate: float | None


def climb_from_thrust(thrust: float, speed_up: float, speed_dn: float) -> float:
    """ArduCopter's thrust-as-climb-rate: 0.5 -> 0, 1 -> +speed_up, 0 -> -speed_dn (m/s up)."""
    thrust = min(1.0, max(0.0, thrust))
    if thrust > 0.5:
        return (thrust - 0.5) * 2.0 * speed_up
    return -(0.5 - thrust) * 2.0 * speed_dn


def _finite(*vals: float) -> bool:
    return all(math.isfinite(v) for v in vals)


def _attitude(q) -> tuple[float, float, float]:
    w, x, y, z = (float(v) for v in q)
    if not _finite(w, x, y, z) or abs(w * w + x * x + y * y + z * z - 1.0) > UNIT_TOLERANCE:
        raise AttitudeStop("Guided: attitude quaternion not unit length")
    return euler_from_quaternion((x, y, z, w))


def decode_copter(type_mask: int, q, body_rates, thrust: float, guid_options: int,
                  speed_up: float, speed_dn: float) -> AttitudeTarget:
    """One SET_ATTITUDE_TARGET for ArduCopter's GUIDED; raises AttitudeStop where ArduCopter
    stops instead. speed_up / speed_dn: WPNAV_SPEED_UP / _DN in m/s."""
    if type_mask & THROTTLE_IGNORE:
        raise AttitudeStop("")
    attitude = None if type_mask & ATTITUDE_IGNORE else _attitude(q)
    ignored = type_mask & RATES_IGNORE
    if ignored == RATES_IGNORE:
        rates = (0.0, 0.0, 0.0)
    elif ignored == 0:
        rates = tuple(float(r) for r in body_rates)
        if not _finite(*rates):
            raise AttitudeStop("Guided: body rates not finite")
    else:
        raise AttitudeStop(f"Guided: partial body rate mask 0x{type_mask:x}")
    thrust = float(thrust)
    if not _finite(thrust):
        raise AttitudeStop("Guided: thrust not finite")
    if guid_options & THRUST_AS_THRUST:
        return AttitudeTarget(attitude, rates, 0.0, min(1.0, max(-1.0, thrust)))
    return AttitudeTarget(attitude, rates, climb_from_thrust(thrust, speed_up, speed_dn), None)


def decode_rover(type_mask: int, q, body_yaw_rate: float, thrust: float,
                 default_speed: float) -> RoverAttitudeTarget | None:
    """One SET_ATTITUDE_TARGET for ArduRover's GUIDED; None when ArduRover ignores it
    (THROTTLE_IGNORE) or it is not finite. default_speed: m/s."""
    if type_mask & THROTTLE_IGNORE or not _finite(float(thrust)):
        return None
    speed = default_speed * min(1.0, max(-1.0, float(thrust)))
    if type_mask & YAW_RATE_IGNORE:
        w, x, y, z = (float(v) for v in q)
        if not _finite(w, x, y, z):
            return None
        # ArduRover takes the yaw of whatever it is sent: a zero quaternion is north
        heading = 0.0 if w == x == y == z == 0.0 else euler_from_quaternion((x, y, z, w))[2]
        return RoverAttitudeTarget(speed, heading, None)
    if not _finite(float(body_yaw_rate)):
        return None
    return RoverAttitudeTarget(speed, None, float(body_yaw_rate))
