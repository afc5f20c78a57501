"""Stamped values (a frame id and a sim-time stamp attached to data) and LATEST.

Stamps are float seconds of sim time. ``0.0`` is a real time (a sim clock may
start at 0); "the latest available" is spelled :data:`LATEST`, never 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Union

import numpy as np

from .errors import InvalidArgumentException
from .transform import Transform, _as_floats, _checked_quat, _compose, _readonly


class _Latest:
    """Type of :data:`LATEST`; a singleton."""

    __slots__ = ()
    _instance: "_Latest | None" = None

    def __new__(cls) -> "_Latest":
        if cls._instance is None:
            cls._instance = super().__new__(cls)
        return cls._instance

    def __repr__(self) -> str:
        return "LATEST"

    def __reduce__(self):
        return (_Latest, ())


#: tf2's ``Time(0)``: "the latest common time" of the frames involved. For a chain
#: of dynamic edges that is the minimum over the edges of each edge's newest stamp;
#: static edges do not constrain it; a chain of only static edges (or a frame to
#: itself) resolves it to stamp 0.0. Unlike ROS, a numeric ``0.0`` is *not* LATEST:
#: it is the sim time 0.0.
LATEST = _Latest()

TimeLike = Union[float, int, _Latest]


def check_time(t: Any, what: str = "time") -> float | _Latest:
    """LATEST passes through; numbers must be finite; anything else is invalid."""
    if t is LATEST:
        return t
    if isinstance(t, (bool, str, bytes)):
        raise InvalidArgumentException(f"{what} must be a finite number of seconds or LATEST, got {t!r}")
    try:
        f = float(t)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentException(
            f"{what} must be a finite number of seconds or LATEST, got {t!r}") from e
    if not math.isfinite(f):
        raise InvalidArgumentException(f"{what} must be finite, got {f!r}")
    return f


@dataclass(frozen=True, slots=True)
class TransformStamped:
    """The pose of ``child_frame_id`` in ``frame_id`` at ``stamp``.

    Maps data expressed in ``child_frame_id`` into ``frame_id``. Construction
    does not validate (the buffer does on insert); ``transform`` must be a
    :class:`Transform`.
    """

    frame_id: str
    child_frame_id: str
    stamp: float
    transform: Transform

    def __repr__(self) -> str:
        return (f"TransformStamped(frame_id={self.frame_id!r}, child_frame_id="
                f"{self.child_frame_id!r}, stamp={self.stamp!r}, transform={self.transform!r})")


def _vec3(v: Any, what: str) -> np.ndarray:
    a = np.array(v, dtype=np.float64)  # a private copy: stamped values are immutable
    if not (a.shape == (3,) or (a.ndim == 2 and a.shape[1] == 3)):
        raise InvalidArgumentException(f"{what} must have shape (3,) or (N, 3), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InvalidArgumentException(f"{what} must be finite, got {a}")
    return _readonly(a)


@dataclass(frozen=True, eq=False)
class PointStamped:
    """A point (shape (3,) or (N, 3)) in ``frame_id`` at ``stamp``."""

    frame_id: str
    stamp: TimeLike
    point: np.ndarray = field(repr=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vec3(self.point, "point"))
        object.__setattr__(self, "stamp", check_time(self.stamp, "stamp"))


@dataclass(frozen=True, eq=False)
class VectorStamped:
    """A free vector (shape (3,) or (N, 3)) in ``frame_id`` at ``stamp``; translation does not apply."""

    frame_id: str
    stamp: TimeLike
    vector: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "vector", _vec3(self.vector, "vector"))
        object.__setattr__(self, "stamp", check_time(self.stamp, "stamp"))


@dataclass(frozen=True, eq=False)
class PoseStamped:
    """A pose in ``frame_id`` at ``stamp``: ``position`` (3,), ``orientation`` (x, y, z, w)."""

    frame_id: str
    stamp: TimeLike
    position: np.ndarray
    orientation: np.ndarray

    def __post_init__(self) -> None:
        p = _as_floats(self.position, 3, "position")
        q = _checked_quat(_as_floats(self.orientation, 4, "orientation"), "orientation")
        object.__setattr__(self, "position", _readonly(np.array(p)))
        object.__setattr__(self, "orientation", _readonly(np.array(q)))
        object.__setattr__(self, "stamp", check_time(self.stamp, "stamp"))

    def as_transform(self) -> Transform:
        """The pose as a Transform (the posed frame's pose in ``frame_id``)."""
        return Transform._of(tuple(self.position.tolist()) + tuple(self.orientation.tolist()))


_new = object.__new__
_set_v = Transform.__dict__["_v"].__set__
_set_frame_id = TransformStamped.__dict__["frame_id"].__set__
_set_child_frame_id = TransformStamped.__dict__["child_frame_id"].__set__
_set_stamp = TransformStamped.__dict__["stamp"].__set__
_set_transform = TransformStamped.__dict__["transform"].__set__


def stamped_of(frame_id: str, child_frame_id: str, stamp: float, v: tuple) -> TransformStamped:
    """TransformStamped(frame_id, child_frame_id, stamp, Transform of the 7-tuple v) from
    values already checked, without checking them again (the buffer's lookup results)."""
    tr = _new(Transform)
    _set_v(tr, v)
    ts = _new(TransformStamped)
    _set_frame_id(ts, frame_id)
    _set_child_frame_id(ts, child_frame_id)
    _set_stamp(ts, stamp)
    _set_transform(ts, tr)
    return ts


def _built(cls: type, **fields: Any) -> Any:
    """A frozen stamped value from fields already checked, without copying them."""
    obj = _new(cls)
    for k, val in fields.items():
        object.__setattr__(obj, k, val)
    return obj


def transformed(data: "PointStamped | VectorStamped | PoseStamped",
                ts: TransformStamped) -> "PointStamped | VectorStamped | PoseStamped":
    """``data`` (in ts.child_frame_id) expressed in ts.frame_id, stamped ts.stamp: a
    point moves by the whole transform, a vector is only rotated, a pose is composed."""
    tr = ts.transform
    if isinstance(data, PointStamped):
        return _built(PointStamped, frame_id=ts.frame_id, stamp=ts.stamp,
                      point=_readonly(tr.apply_point(data.point)))
    if isinstance(data, VectorStamped):
        return _built(VectorStamped, frame_id=ts.frame_id, stamp=ts.stamp,
                      vector=_readonly(tr.apply_vector(data.vector)))
    v = _compose(tr._v, data.as_transform()._v)
    return _built(PoseStamped, frame_id=ts.frame_id, stamp=ts.stamp,
                  position=_readonly(np.array(v[:3])), orientation=_readonly(np.array(v[3:])))


__all__ = ["LATEST", "TransformStamped", "PointStamped", "VectorStamped", "PoseStamped",
           "check_time", "stamped_of", "transformed"]
