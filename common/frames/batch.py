"""Rotation math on many vectors at once: the batch forms beside `Transform` (one value).

Quaternions are (x, y, z, w) rows, as everywhere in common.frames; a quaternion maps body (FRD)
vectors into world (NED) for the vehicles. `Transform` is the API for one transform; these are
for the fleet and for scoring, which rotate (n, 3) arrays every step. Small batches (n <= 8)
run on floats, since numpy's per-call cost dominates there; larger ones on numpy columns.
Both paths compute the same expressions, so they agree to rounding.
"""
from __future__ import annotations

import math

import numpy as np

SMALL = 8      # up to this many rows, Python floats beat numpy's per-call overhead


def quat_mul_one(ax: float, ay: float, az: float, aw: float,
                 bx: float, by: float, bz: float, bw: float) -> tuple[float, float, float, float]:
    """Hamilton product a*b of two xyzw quaternions given as floats (apply b, then a)."""
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def rotate_one(ux: float, uy: float, uz: float, w: float, vx: float, vy: float, vz: float,
               s: float = 1.0) -> tuple[float, float, float]:
    """R(q) v for one unit xyzw quaternion and vector given as floats; s = -1.0 gives R(q)^T v.
    The same expression as `rotate`, so both agree to the last bit."""
    ux, uy, uz = s * ux, s * uy, s * uz
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    return (vx + w * tx + uy * tz - uz * ty, vy + w * ty + uz * tx - ux * tz,
            vz + w * tz + ux * ty - uy * tx)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a*b of (n, 4) xyzw arrays, row by row (apply b, then a)."""
    if len(a) <= SMALL:
        out = [quat_mul_one(*qa, *qb) for qa, qb in zip(a.tolist(), b.tolist())]
        return np.array(out, dtype=float).reshape(len(a), 4)
    ax, ay, az, aw = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bx, by, bz, bw = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=1)


def rotate(q: np.ndarray, v: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Rotate (n, 3) vectors by (n, 4) unit quaternions: R(q) v, or R(q)^T v when inverse.

    v' = v + 2w (u x v) + 2 u x (u x v), written out (np.cross is slow on small arrays).
    """
    s = -1.0 if inverse else 1.0
    if len(q) <= SMALL:
        out = [rotate_one(*qi, *vi, s) for qi, vi in zip(q.tolist(), v.tolist())]
        return np.array(out, dtype=float).reshape(len(q), 3)
    ux, uy, uz, w = s * q[:, 0], s * q[:, 1], s * q[:, 2], q[:, 3]
    vx, vy, vz = v[:, 0], v[:, 1], v[:, 2]
    tx = 2.0 * (uy * vz - uz * vy)
    ty = 2.0 * (uz * vx - ux * vz)
    tz = 2.0 * (ux * vy - uy * vx)
    return np.column_stack((vx + w * tx + uy * tz - uz * ty,
                            vy + w * ty + uz * tx - ux * tz,
                            vz + w * tz + ux * ty - uy * tx))


def body_z_axis(q) -> np.ndarray:
    """The body z axis in the parent frame, R(q)[:, 2], of (..., 4) xyzw quaternions -> (..., 3).

    For a drone (FRD body in NED) it points down through the belly; its horizontal part is
    sin(tilt) long, tilt being the angle between body z and world z.
    """
    q = np.asarray(q, float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)], axis=-1)


def yaw_of(qx, qy, qz, qw, atan2=np.arctan2):
    """Yaw (rad, ZYX Euler, about parent z, right-handed) of quaternions given component-wise.

    Components are floats or arrays of one shape; pass `math.atan2` for floats (numpy's per-call
    cost is the larger part there). Equal to euler_from_quaternion(q)[2] except exactly at
    pitch +-90 deg, where yaw is not defined and euler_from_quaternion sets roll to 0 instead.
    """
    return atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def wrap_pi(a):
    """Angle(s) in rad wrapped to [-pi, pi); floats and arrays alike."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def ground_point(translation, rotation, height, offset=(0.0, 0.0)) -> np.ndarray:
    """The ground point under a drone-attached frame, in the parent (world) frame, xy only.

    The point is written in the frame as (offset_x, offset_y, +height) (FRD: "below by the
    drone's height") and mapped through the frame's world transform (translation (..., 3),
    rotation (..., 4) xyzw); z is dropped. Broadcasts over leading dimensions. With offset 0 its
    distance from the frame's own xy is height * sin(tilt): the wobble the yaw-only frame removes.
    """
    t = np.asarray(translation, float)
    q = np.asarray(rotation, float)
    h = np.asarray(height, float)
    ox, oy = float(offset[0]), float(offset[1])
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    # first two rows of R(q) applied to (ox, oy, h)
    px = (1.0 - 2.0 * (y * y + z * z)) * ox + 2.0 * (x * y - w * z) * oy + 2.0 * (x * z + w * y) * h
    py = 2.0 * (x * y + w * z) * ox + (1.0 - 2.0 * (x * x + z * z)) * oy + 2.0 * (y * z - w * x) * h
    return np.stack([t[..., 0] + px, t[..., 1] + py], axis=-1)
