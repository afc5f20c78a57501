"""ArduCopter's stick scaling (Attitude.cpp, mode.cpp), pure: the sticks (rc_input.Sticks)
and parameters in, what the pilot asks for out.

- lean_angles: get_pilot_desired_lean_angles: roll and pitch sticks (-1..1 after the dead
  zone) limited to the unit circle, times ANGLE_MAX (cdeg) and capped at `angle_max`; roll
  then becomes atan(cos(pitch) tan(roll)) (a body-frame lean). rad; roll right, pitch
  nose-up positive.
- climb_rate: get_pilot_desired_climb_rate: the throttle (0..1000) about its mid stick with
  THR_DZ (clamped 0..400) either side: below, PILOT_SPEED_DN (0: PILOT_SPEED_UP) times the
  fraction down to 0; above, PILOT_SPEED_UP times the fraction up to 1000. m/s, up positive.
- throttle: get_pilot_desired_throttle (STABILIZE, ACRO): mid stick is `hover` (MOT_THST_HOVER)
  through ArduCopter's expo; 0..1 collective.
- yaw_rate: PILOT_Y_RATE (deg/s) times the yaw stick through PILOT_Y_EXPO. rad/s, right.
- velocity: LOITER's pilot velocity, the square stick range mapped into a circle, times
  LOIT_SPEED (cm/s), rotated by the heading: world (north, east) m/s.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

from vehicle.autopilot.rc_input import Sticks


def lean_angles(s: Sticks, angle_max: float) -> tuple[float, float]:
    """(roll, pitch) rad the sticks ask for, |each| <= angle_max (rad)."""
    roll, pitch = s.roll, s.pitch
    total = math.hypot(roll, pitch)
    if total > 1.0:
        roll, pitch = roll / total, pitch / total
    roll, pitch = roll * angle_max, pitch * angle_max
    return math.atan(math.cos(pitch) * math.tan(roll)), pitch


def climb_rate(s: Sticks, p: Mapping[str, float]) -> float:
    """m/s up the throttle stick asks for (0 in the dead band about mid stick)."""
    mid = float(s.throttle_mid)
    dz = max(0.0, min(400.0, float(p.get("THR_DZ", 100))))
    top, bottom = mid + dz, mid - dz
    thr = max(0.0, min(1000.0, float(s.throttle)))
    up = abs(float(p.get("PILOT_SPEED_UP", 250)))
    dn = abs(float(p.get("PILOT_SPEED_DN", 0))) or up
    if thr < bottom and bottom > 0:
        return dn * (thr - bottom) / bottom / 100.0
    if thr > top and top < 1000:
        return up * (thr - top) / (1000.0 - top) / 100.0
    return 0.0


def throttle(s: Sticks, hover: float) -> float:
    """0..1 collective of a manual-throttle mode (mid stick -> hover through the expo)."""
    mid = s.throttle_mid if s.throttle_mid > 0 else 500
    thr = max(0, min(1000, s.throttle))
    if thr < mid:
        t_in = thr * 0.5 / mid
    elif thr > mid:
        t_in = 0.5 + (thr - mid) * 0.5 / (1000 - mid)
    else:
        t_in = 0.5
    expo = max(-0.5, min(1.0, -(hover - 0.5) / 0.375))
    return t_in * (1.0 - expo) + expo * t_in ** 3


def yaw_rate(s: Sticks, p: Mapping[str, float]) -> float:
    """rad/s the yaw stick asks for (right positive)."""
    y = s.yaw
    expo = max(-0.5, min(1.0, float(p.get("PILOT_Y_EXPO", 0.0))))
    if expo:
        y = (1.0 - expo) * y + expo * y ** 3
    return math.radians(float(p.get("PILOT_Y_RATE", 202.5))) * y


def velocity(s: Sticks, p: Mapping[str, float], yaw: float) -> tuple[float, float]:
    """(north, east) m/s of LOITER's pilot velocity at heading yaw (rad)."""
    fwd, right = -s.pitch, s.roll
    # the square stick range onto the unit circle (full diagonal = full speed)
    m = max(abs(fwd), abs(right))
    r = math.hypot(fwd, right)
    if r > 1e-9:
        fwd, right = fwd * m / r, right * m / r
    speed = float(p.get("LOIT_SPEED", 1250)) / 100.0
    c, sn = math.cos(yaw), math.sin(yaw)
    return speed * (fwd * c - right * sn), speed * (fwd * sn + right * c)


def sticks_centred(s: Sticks | None) -> bool:
    """No roll, pitch or yaw asked for (throttle not looked at)."""
    return s is None or (s.roll == 0.0 and s.pitch == 0.0 and s.yaw == 0.0)
