"""SET_POSITION_TARGET_* decoding as ArduPilot's GUIDED mode reads it (pure, no I/O).

ArduPilot Copter (GCS_Mavlink.cpp handle_set_position_target_local_ned):
  frames LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED; BODY_* rotate x/y (position,
  velocity, acceleration) by the vehicle's yaw and make yaw relative; every frame but LOCAL_NED
  makes the position an offset from the current position.
  type_mask: pos+vel(+acc) -> position with velocity/acceleration feed-forward; vel(+acc) ->
  velocity target; acc only -> acceleration target; pos only -> position target; any other
  combination (nothing, pos+acc without vel, FORCE_SET with acceleration) is invalid and the
  vehicle stops (holds). We also refuse partial position/velocity/acceleration masks (ArduPilot
  silently uses all three axes), NaN/inf, and absurd values; the caller holds and says why.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames.batch import wrap_pi

POS_BITS = 0b111
VEL_BITS = 0b111000
ACC_BITS = 0b111000000
FORCE_SET = 512
YAW_IGNORE = 1024
YAW_RATE_IGNORE = 2048

LOCAL_FRAMES = {mav.MAV_FRAME_LOCAL_NED, mav.MAV_FRAME_LOCAL_OFFSET_NED,
                mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED}
BODY_FRAMES = {mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED}
GLOBAL_AMSL = {mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT}
GLOBAL_REL = {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
GLOBAL_TERRAIN = {mav.MAV_FRAME_GLOBAL_TERRAIN_ALT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}

MAX_DISTANCE = 10_000.0    # m from the world origin: further is nonsense for this world
MAX_SPEED = 50.0           # m/s
MAX_ACCEL = 50.0           # m/s^2
MAX_YAW_RATE = 10.0        # rad/s


class TargetError(ValueError):
    """The target is refused; str() is the STATUSTEXT reason."""


@dataclass
class GuidedTarget:
    """A target in world NED; kind is 'pos', 'posvel', 'vel' or 'acc'."""
    kind: str
    pos: np.ndarray | None
    vel: np.ndarray | None
    acc: np.ndarray | None
    yaw: float | None
    yaw_rate: float | None

    @property
    def type_mask(self) -> int:
        m = 0
        if self.pos is None:
            m |= POS_BITS
        if self.vel is None:
            m |= VEL_BITS
        if self.acc is None:
            m |= ACC_BITS
        if self.yaw is None:
            m |= YAW_IGNORE
        if self.yaw_rate is None:
            m |= YAW_RATE_IGNORE
        return m


def _rot(v: np.ndarray, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def _finite(name: str, v) -> None:
    if not np.all(np.isfinite(v)):
        raise TargetError(f"Guided: {name} not finite")


def _kind(type_mask: int, pos_used: bool) -> tuple[str, bool, bool, bool]:
    groups = []
    for bits, name in ((POS_BITS, "position"), (VEL_BITS, "velocity"), (ACC_BITS, "acceleration")):
        g = type_mask & bits
        if g not in (0, bits):
            raise TargetError(f"Guided: partial {name} mask 0x{type_mask:x}")
        groups.append(g == 0)
    use_pos, use_vel, use_acc = groups
    use_pos = use_pos and pos_used
    if type_mask & FORCE_SET and use_acc:
        raise TargetError("Guided: force setpoints not supported")
    if use_pos and use_vel:
        return "posvel", use_pos, use_vel, use_acc
    if use_vel:
        return "vel", use_pos, use_vel, use_acc
    if use_acc and not use_pos:
        return "acc", use_pos, use_vel, use_acc
    if use_pos and not use_acc:
        return "pos", use_pos, use_vel, use_acc
    raise TargetError(f"Guided: invalid type_mask 0x{type_mask:x}")


def _yaws(type_mask: int, yaw: float, yaw_rate: float, relative: bool, cur_yaw: float):
    y = yr = None
    if not type_mask & YAW_IGNORE:
        _finite("yaw", yaw)
        y = float(yaw) + (cur_yaw if relative else 0.0)
        y = wrap_pi(y)
    if not type_mask & YAW_RATE_IGNORE:
        _finite("yaw_rate", yaw_rate)
        if abs(yaw_rate) > MAX_YAW_RATE:
            raise TargetError(f"Guided: yaw rate {yaw_rate:g} rad/s too high")
        yr = float(yaw_rate)
    return y, yr


def _check_limits(pos, vel, acc) -> None:
    if pos is not None and np.linalg.norm(pos) > MAX_DISTANCE:
        raise TargetError(f"Guided: target {np.linalg.norm(pos):.0f} m away, limit {MAX_DISTANCE:.0f} m")
    if vel is not None and np.linalg.norm(vel) > MAX_SPEED:
        raise TargetError(f"Guided: speed {np.linalg.norm(vel):.1f} m/s too high")
    if acc is not None and np.linalg.norm(acc) > MAX_ACCEL:
        raise TargetError(f"Guided: accel {np.linalg.norm(acc):.1f} m/s/s too high")


def decode_local(frame: int, type_mask: int, p, v, a, yaw: float, yaw_rate: float,
                 cur_pos: np.ndarray, cur_yaw: float) -> GuidedTarget:
    """SET_POSITION_TARGET_LOCAL_NED -> GuidedTarget in world NED; raises TargetError."""
    if frame not in LOCAL_FRAMES:
        raise TargetError(f"Guided: frame {frame} not supported")
    kind, use_pos, use_vel, use_acc = _kind(type_mask, True)
    body = frame in BODY_FRAMES
    pos = vel = acc = None
    if use_pos:
        pos = np.asarray(p, float)
        _finite("position", pos)
        if body:
            pos = _rot(pos, cur_yaw)
        if frame != mav.MAV_FRAME_LOCAL_NED:
            pos = pos + cur_pos
    if use_vel:
        vel = np.asarray(v, float)
        _finite("velocity", vel)
        if body:
            vel = _rot(vel, cur_yaw)
    if use_acc:
        acc = np.asarray(a, float)
        _finite("acceleration", acc)
        if body:
            acc = _rot(acc, cur_yaw)
    y, yr = _yaws(type_mask, yaw, yaw_rate, body, cur_yaw)
    _check_limits(pos, vel, acc)
    return GuidedTarget(kind, pos, vel, acc, y, yr)


def decode_global(frame: int, type_mask: int, lat_int: int, lon_int: int, alt: float, v, a,
                  yaw: float, yaw_rate: float, to_ned, home_alt: float, cur_yaw: float) -> GuidedTarget:
    """SET_POSITION_TARGET_GLOBAL_INT -> GuidedTarget; `to_ned(lat, lon, alt_amsl)`."""
    if frame in GLOBAL_TERRAIN:
        raise TargetError("Guided: terrain frames not supported (no terrain data)")
    if frame not in GLOBAL_AMSL | GLOBAL_REL:
        raise TargetError(f"Guided: frame {frame} not supported")
    kind, use_pos, use_vel, use_acc = _kind(type_mask, True)
    pos = vel = acc = None
    if use_pos:
        lat, lon = lat_int * 1e-7, lon_int * 1e-7
        _finite("position", [lat, lon, alt])
        if abs(lat) > 90 or abs(lon) > 180 or (lat_int == 0 and lon_int == 0):
            raise TargetError("Guided: invalid latitude/longitude")
        amsl = alt + (home_alt if frame in GLOBAL_REL else 0.0)
        pos = np.asarray(to_ned(lat, lon, amsl), float)
    if use_vel:
        vel = np.asarray(v, float)
        _finite("velocity", vel)
    if use_acc:
        acc = np.asarray(a, float)
        _finite("acceleration", acc)
    y, yr = _yaws(type_mask, yaw, yaw_rate, False, cur_yaw)
    _check_limits(pos, vel, acc)
    return GuidedTarget(kind, pos, vel, acc, y, yr)
