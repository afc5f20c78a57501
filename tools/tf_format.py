"""tf_echo's output shape, shared by `towerlink tf-echo` and `towerlink static-transform`.

ROS `tf_echo SOURCE TARGET` (and ROS 2 `tf2_echo`) looks up
``lookup_transform(SOURCE, TARGET)`` -- target_frame=SOURCE, source_frame=TARGET --
i.e. the pose of TARGET expressed in SOURCE (the transform that maps points given in
TARGET into SOURCE), and prints, with 3 decimals fixed::

    At time 12.340
    - Translation: [x, y, z]
    - Rotation: in Quaternion [x, y, z, w]
                in RPY (radian) [roll, pitch, yaw]
                in RPY (degree) [roll, pitch, yaw]

RPY is tf's ``getRPY``: fixed-axis roll about x, then pitch about y, then yaw about z,
R = Rz(yaw) Ry(pitch) Rx(roll), from ``common.frames.euler_from_quaternion``. Printed in
roll, pitch, yaw order, as tf_echo does.

Pure formatting: accepts a ``common.frames.TransformStamped``, a ``Transform``, or a
plain ``(translation, rotation_xyzw)`` pair; no dependency on the frame buffer.
"""
from __future__ import annotations

import math

from common.frames import euler_from_quaternion

__all__ = ["format_tf_echo", "format_number", "split_transform"]




def split_transform(obj) -> tuple[tuple[float, float, float], tuple[float, float, float, float], float | None]:
    """(translation, rotation xyzw, stamp or None) from a TransformStamped, Transform or pair."""
    stamp = getattr(obj, "stamp", None)
    tf = getattr(obj, "transform", obj)
    if hasattr(tf, "translation") and hasattr(tf, "rotation"):
        t, r = tf.translation, tf.rotation
    else:
        t, r = obj
    t = tuple(float(v) for v in t)
    r = tuple(float(v) for v in r)
    if len(t) != 3 or len(r) != 4:
        raise ValueError("need translation (3) and rotation quaternion (4)")
    return t, r, (None if stamp is None else float(stamp))


def _fmt(vals, precision: int) -> str:
    return "[" + ", ".join(format_number(v, precision) for v in vals) + "]"


def format_number(v: float, precision: int = 3) -> str:
    """Fixed-point text of v; a value that rounds to zero prints as 0, never -0."""
    s = f"{v:.{precision}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


def format_tf_echo(stamped_or_transform, time: float | None = None, precision: int = 3) -> str:
    """tf_echo's block for one transform, without a trailing newline.

    `time` is printed on the "At time" line; when None, the stamp of a TransformStamped
    is used, and 0.0 for a bare Transform (static transforms print 0.000 in tf_echo too).
    """
    t, q, stamp = split_transform(stamped_or_transform)
    if time is None:
        time = stamp if stamp is not None else 0.0
    roll, pitch, yaw = euler_from_quaternion(q)
    deg = tuple(math.degrees(a) for a in (roll, pitch, yaw))
    return "\n".join([
        f"At time {float(time):.{precision}f}",
        f"- Translation: {_fmt(t, precision)}",
        f"- Rotation: in Quaternion {_fmt(q, precision)}",
        f"            in RPY (radian) {_fmt((roll, pitch, yaw), precision)}",
        f"            in RPY (degree) {_fmt(deg, precision)}",
    ])
