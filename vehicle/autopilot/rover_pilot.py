"""ArduRover's pilot input (Rover/mode.cpp get_pilot_input, get_pilot_desired_steering_and_
speed, mode_manual.cpp, mode_acro.cpp, mode_steering.cpp), pure: sticks (rc_input.Sticks)
and parameters in, what each mode drives out.

The steering stick is RCMAP_ROLL's channel, the throttle RCMAP_THROTTLE's, both -1..1 about
their trims (norm_input_dz; positive: right, forward).
- MANUAL: the throttle as a fraction of the drive's top speed (SIM_RVR_MAX_SPD, towerlink's
  motor) and the steering as a fraction of its turn-rate limit (ATC_STR_RAT_MAX), as the
  outputs pass straight to the skid-steering mixer.
- ACRO: speed = throttle x the pilot's top speed (SPEED_MAX, or the top speed when 0),
  turn rate = steering x ACRO_TURN_RATE (deg/s).
- STEERING: the same speed; the steering a lateral acceleration (steering x TURN_MAX_G g),
  its turn rate that over the speed, within ACRO_TURN_RATE (turning in place when stopped).
Speeds m/s (negative backwards), turn rates rad/s (right positive).
"""
from __future__ import annotations

import math
from collections.abc import Mapping

from vehicle.autopilot.rc_input import Sticks

GRAVITY = 9.80665


def manual(s: Sticks, p: Mapping[str, float], top_speed: float) -> tuple[float, float]:
    """(speed, turn rate) of MANUAL's pass-through."""
    return s.throttle_norm * top_speed, s.roll * math.radians(float(p.get("ATC_STR_RAT_MAX", 0)) or 120.0)


def pilot_speed(s: Sticks, p: Mapping[str, float], top_speed: float) -> float:
    """ACRO's and STEERING's target speed."""
    return s.throttle_norm * (float(p.get("SPEED_MAX", 0)) or top_speed)


def acro(s: Sticks, p: Mapping[str, float], top_speed: float) -> tuple[float, float]:
    """(speed, turn rate) of ACRO."""
    return pilot_speed(s, p, top_speed), s.roll * math.radians(float(p.get("ACRO_TURN_RATE", 180)))


def steering(s: Sticks, p: Mapping[str, float], top_speed: float) -> tuple[float, float]:
    """(speed, turn rate) of STEERING."""
    speed = pilot_speed(s, p, top_speed)
    limit = math.radians(float(p.get("ACRO_TURN_RATE", 180)))
    if abs(speed) < 0.1:
        return speed, s.roll * limit
    lat = s.roll * float(p.get("TURN_MAX_G", 0.6)) * GRAVITY
    return speed, max(-limit, min(limit, lat / abs(speed)))
