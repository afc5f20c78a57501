"""Checks of what callers hand the buffer: frame ids, timeouts, cache_time, stored transforms.

Each raises :class:`InvalidArgumentException` (a ValueError) naming the argument.
"""
from __future__ import annotations

import math
from typing import Any

from .errors import InvalidArgumentException
from .stamped import LATEST, TransformStamped, check_time
from .transform import Transform

_isfinite = math.isfinite


def check_frame_id(frame: Any, what: str) -> None:
    """tf2's rules for a frame id: a non-empty str not starting with '/'."""
    if type(frame) is not str:
        raise InvalidArgumentException(
            f"Invalid argument passed to {what}: frame ids must be str, got {frame!r}")
    if not frame:
        raise InvalidArgumentException(
            f"Invalid argument passed to {what}: in tf2 frame_ids cannot be empty")
    if frame[0] == "/":
        raise InvalidArgumentException(
            f"Invalid argument passed to {what}: in tf2 frame_ids cannot start with a '/' "
            f"like: \"{frame}\"")


def check_timeout(timeout: Any) -> float:
    """A timeout in wall seconds: finite and >= 0."""
    try:
        t = float(timeout)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentException(f"timeout must be a number of seconds, got {timeout!r}") from e
    if not (_isfinite(t) and t >= 0.0):
        raise InvalidArgumentException(f"timeout must be finite and >= 0, got {timeout!r}")
    return t


def check_cache_time(cache_time: Any) -> float:
    """A buffer's window in seconds: finite and > 0."""
    try:
        ct = float(cache_time)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentException(f"cache_time must be seconds, got {cache_time!r}") from e
    if not (_isfinite(ct) and ct > 0.0):
        raise InvalidArgumentException(f"cache_time must be finite and > 0, got {cache_time!r}")
    return ct


def checked_insert(ts: TransformStamped, fn: str) -> tuple[str, str, float, tuple]:
    """(parent, child, stamp, 7-tuple) of a transform to store, checked for ``fn``.

    Refuses bad ids, parent == child (tf2's TF_SELF_TRANSFORM), a stamp that is not a
    finite number (LATEST included) and a transform that is not a :class:`Transform`.
    """
    parent = ts.frame_id
    child = ts.child_frame_id
    stamp = ts.stamp
    tr = ts.transform
    if type(parent) is not str or not parent or parent[0] == "/":
        check_frame_id(parent, f"{fn} frame_id")
    if type(child) is not str or not child or child[0] == "/":
        check_frame_id(child, f"{fn} child_frame_id")
    if parent == child:
        raise InvalidArgumentException(
            f"{fn}: frame_id and child_frame_id are both \"{child}\"; a frame cannot be "
            f"its own parent")
    if type(stamp) is not float or not _isfinite(stamp):
        if stamp is LATEST:
            raise InvalidArgumentException(
                f"{fn}: a stored transform needs a real stamp, not LATEST "
                f"(edge {parent} -> {child})")
        stamp = check_time(stamp, f"{fn} stamp of {parent} -> {child}")
    if type(tr) is not Transform and not isinstance(tr, Transform):
        raise InvalidArgumentException(
            f"{fn}: transform of {parent} -> {child} must be a Transform, got {type(tr).__name__}")
    return parent, child, stamp, tr._v


__all__ = ["check_frame_id", "check_timeout", "check_cache_time", "checked_insert"]
