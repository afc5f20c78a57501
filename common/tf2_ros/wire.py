"""TOWERLINK_TRANSFORM / TOWERLINK_STATIC_TRANSFORM on the wire (the one home of this encoding).

Used by the nodes (common.tf2_ros) and by the bridge (bridge.codec re-exports these).
Frame ids are at most 16 bytes on the wire (char[16]); a longer id is a ValueError,
never silently cut. Stamps are seconds on the sender's timeline (sim time), sent as
microseconds; a negative or non-finite stamp is a ValueError.
"""
from __future__ import annotations

import math

from common.mavlink.dialect import towerlink as tl
from common.frames import Transform, TransformStamped
from common.mavlink.mavstr import mav_str

STATIC_FLAG = tl.TOWERLINK_TRANSFORM_FLAGS_STATIC
FRAME_ID_LEN = 16


def frame_bytes(name: str) -> bytes:
    b = name.encode()
    if len(b) > FRAME_ID_LEN:
        raise ValueError(f"frame id {name!r} is longer than {FRAME_ID_LEN} bytes")
    return b


def _usec(stamp: float) -> int:
    s = float(stamp)
    if not math.isfinite(s) or s < 0:
        raise ValueError(f"stamp must be finite and >= 0 s, got {stamp!r}")
    return int(round(s * 1e6))


def _numbers(tr) -> tuple[list[float], list[float]]:
    """(translation, rotation) of a transform as lists of floats (a Transform's own tuples: the
    bridge sends about three a frame)."""
    if type(tr) is Transform:
        return list(tr.xyz), list(tr.xyzw)
    return [float(v) for v in tr.translation], [float(v) for v in tr.rotation]


def transform_message(ts: TransformStamped, static: bool = False):
    """TOWERLINK_TRANSFORM message object for one stamped transform."""
    translation, rotation = _numbers(ts.transform)
    return tl.MAVLink_towerlink_transform_message(
        _usec(ts.stamp), frame_bytes(ts.frame_id), frame_bytes(ts.child_frame_id), translation, rotation,
        STATIC_FLAG if static else 0)


def transform_from_message(msg) -> tuple[TransformStamped, bool]:
    """(TransformStamped, is_static) from a decoded TOWERLINK_TRANSFORM or TOWERLINK_STATIC_TRANSFORM.

    Raises TransformException (common.frames) for a rotation that is not a quaternion or
    non-finite numbers.
    """
    stamp = getattr(msg, "time_usec", 0) / 1e6
    tr = Transform(translation=tuple(msg.translation), rotation=tuple(msg.rotation))
    static = msg.get_type() == "TOWERLINK_STATIC_TRANSFORM" or bool(msg.flags & STATIC_FLAG)
    return TransformStamped(mav_str(msg.frame_id), mav_str(msg.child_frame_id), float(stamp), tr), static


def static_transform_message(ts: TransformStamped, target_system: int = 0):
    """TOWERLINK_STATIC_TRANSFORM asking a bridge to add `ts` to its buffer."""
    translation, rotation = _numbers(ts.transform)
    return tl.MAVLink_towerlink_static_transform_message(
        target_system, 0, frame_bytes(ts.frame_id), frame_bytes(ts.child_frame_id), translation, rotation)
