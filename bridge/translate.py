"""Frame translation of MAVLink position messages (pure: a Transform in, fields out).

A transform ``T`` here is ``lookup_transform(dst, src)``: it maps data expressed in
``src`` into ``dst``. Positions are points (rotation and translation), velocities and
accelerations are vectors (rotation only), a yaw is a heading: the direction
(cos yaw, sin yaw, 0) in src, rotated into dst, read back with atan2 (exact for any
rotation, including frames whose z axis is flipped). A yaw rate is a rate about z: it
is scaled by the z-z entry of the rotation (+1 for frames sharing the vertical).

Fields the type_mask says to ignore are passed through unchanged.
"""
from __future__ import annotations

import math

import numpy as np

from common.mavlink.dialect import towerlink as tl

# POSITION_TARGET_TYPEMASK bits
IGNORE_POS = 0b111
IGNORE_VEL = 0b111 << 3
IGNORE_ACC = 0b111 << 6
FORCE_SET = 1 << 9
IGNORE_YAW = 1 << 10
IGNORE_YAW_RATE = 1 << 11

FRAME_LOCAL_NED = tl.MAV_FRAME_LOCAL_NED            # 1
FRAME_LOCAL_OFFSET_NED = tl.MAV_FRAME_LOCAL_OFFSET_NED  # 7
#: frames whose numbers are in the sender's local frame and must be translated
TRANSLATED_FRAMES = (FRAME_LOCAL_NED, FRAME_LOCAL_OFFSET_NED)


def heading(T, yaw: float) -> float:
    """Yaw (rad) in src -> yaw in dst for transform T (dst <- src)."""
    if not math.isfinite(yaw):
        return float(yaw)   # passed on as sent: the vehicle refuses it ("Guided: yaw not finite")
    d = np.asarray(T.apply_vector((math.cos(yaw), math.sin(yaw), 0.0)), dtype=float)
    if abs(d[0]) < 1e-12 and abs(d[1]) < 1e-12:
        return float(yaw)   # heading vertical in dst: nothing better to say
    return math.atan2(d[1], d[0])


def yaw_rate(T, rate: float) -> float:
    R = T.rotation_matrix() if callable(getattr(T, "rotation_matrix", None)) else T.to_matrix()[:3, :3]
    return float(rate * R[2, 2])


def _vec(T, v):
    return tuple(float(a) for a in T.apply_vector(v))


def _pt(T, p):
    return tuple(float(a) for a in T.apply_point(p))


def target_fields(T, coordinate_frame: int, type_mask: int, x, y, z, vx, vy, vz,
                  afx, afy, afz, yaw, yaw_rate_v) -> dict:
    """Translate the numeric fields of a position target (SET_/POSITION_TARGET_LOCAL_NED).

    LOCAL_NED: position is a point; LOCAL_OFFSET_NED: position is an offset (vector).
    Velocity, acceleration (or force) are vectors; yaw a heading; yaw rate about z.
    """
    out = dict(x=x, y=y, z=z, vx=vx, vy=vy, vz=vz, afx=afx, afy=afy, afz=afz, yaw=yaw,
               yaw_rate=yaw_rate_v)
    if not type_mask & IGNORE_POS:
        p = _pt(T, (x, y, z)) if coordinate_frame == FRAME_LOCAL_NED else _vec(T, (x, y, z))
        out["x"], out["y"], out["z"] = p
    if not type_mask & IGNORE_VEL:
        out["vx"], out["vy"], out["vz"] = _vec(T, (vx, vy, vz))
    if not type_mask & IGNORE_ACC:
        out["afx"], out["afy"], out["afz"] = _vec(T, (afx, afy, afz))
    if not type_mask & IGNORE_YAW:
        out["yaw"] = heading(T, yaw)
    if not type_mask & IGNORE_YAW_RATE:
        out["yaw_rate"] = yaw_rate(T, yaw_rate_v)
    return out


def set_position_target(msg, T):
    """A new SET_POSITION_TARGET_LOCAL_NED with msg's fields mapped through T (dst <- src)."""
    f = target_fields(T, msg.coordinate_frame, msg.type_mask, msg.x, msg.y, msg.z, msg.vx,
                      msg.vy, msg.vz, msg.afx, msg.afy, msg.afz, msg.yaw, msg.yaw_rate)
    return tl.MAVLink_set_position_target_local_ned_message(
        msg.time_boot_ms, msg.target_system, msg.target_component, msg.coordinate_frame,
        msg.type_mask, f["x"], f["y"], f["z"], f["vx"], f["vy"], f["vz"], f["afx"], f["afy"],
        f["afz"], f["yaw"], f["yaw_rate"])


def position_target(msg, T):
    """A new POSITION_TARGET_LOCAL_NED (vehicle -> GCS report) mapped through T."""
    f = target_fields(T, msg.coordinate_frame, msg.type_mask, msg.x, msg.y, msg.z, msg.vx,
                      msg.vy, msg.vz, msg.afx, msg.afy, msg.afz, msg.yaw, msg.yaw_rate)
    return tl.MAVLink_position_target_local_ned_message(
        msg.time_boot_ms, msg.coordinate_frame, msg.type_mask, f["x"], f["y"], f["z"], f["vx"],
        f["vy"], f["vz"], f["afx"], f["afy"], f["afz"], f["yaw"], f["yaw_rate"])


def local_position(msg, T):
    """A new LOCAL_POSITION_NED mapped through T: position a point, velocity a vector."""
    x, y, z = _pt(T, (msg.x, msg.y, msg.z))
    vx, vy, vz = _vec(T, (msg.vx, msg.vy, msg.vz))
    return tl.MAVLink_local_position_ned_message(msg.time_boot_ms, x, y, z, vx, vy, vz)


def named_target(msg, T, target_frame: int = FRAME_LOCAL_NED):
    """SET_POSITION_TARGET_LOCAL_NED (LOCAL_NED, world) from a TOWERLINK_POSITION_TARGET.

    T = lookup_transform("world", msg.frame_id). Acceleration is always ignored.
    """
    mask = (msg.type_mask | IGNORE_ACC) & ~FORCE_SET
    f = target_fields(T, FRAME_LOCAL_NED, mask, msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz,
                      0.0, 0.0, 0.0, msg.yaw, msg.yaw_rate)
    return tl.MAVLink_set_position_target_local_ned_message(
        msg.time_boot_ms, msg.target_system, msg.target_component, target_frame, mask,
        f["x"], f["y"], f["z"], f["vx"], f["vy"], f["vz"], 0.0, 0.0, 0.0, f["yaw"], f["yaw_rate"])
