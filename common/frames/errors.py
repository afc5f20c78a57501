"""Typed transform errors, named and shaped like tf2's.

Every error is a :class:`TransformException`. Messages name the frames and the
times involved; the same facts are also kept as attributes so callers need not
parse text.

Hierarchy::

    TransformException
    ├── LookupException              a frame does not exist
    ├── ConnectivityException        frames exist but are in different trees
    ├── ExtrapolationException       requested time outside the data on an edge
    │   ├── PastExtrapolationException    earlier than the oldest sample
    │   └── FutureExtrapolationException  later than the newest sample
    ├── InvalidArgumentException     bad frame id, NaN/inf, bad quaternion, loop ...
    └── TimeoutException             a lookup with a timeout gave up waiting
"""
from __future__ import annotations


class TransformException(Exception):
    """Base of every error raised by :mod:`common.frames`."""


class LookupException(TransformException):
    """A frame id that the buffer has never heard of.

    Attributes: ``frame`` (the missing id), ``argument`` (e.g. ``"target_frame"``).
    """

    def __init__(self, message: str, frame: str | None = None, argument: str | None = None):
        super().__init__(message)
        self.frame = frame
        self.argument = argument


class ConnectivityException(TransformException):
    """Both frames exist but no chain of edges joins them (two or more trees)."""

    def __init__(self, message: str, target_frame: str | None = None,
                 source_frame: str | None = None):
        super().__init__(message)
        self.target_frame = target_frame
        self.source_frame = source_frame


class ExtrapolationException(TransformException):
    """The requested time lies outside the data stored on some edge of the chain.

    Attributes: ``target_frame``, ``source_frame`` (of the lookup), ``edge``
    ``(parent, child)`` whose data was missing, ``requested`` time, and
    ``earliest`` / ``latest`` stamps stored on that edge. For an edge emptied by
    ``Buffer.clear()`` the parent is None (unknown, as in tf2) and there are no stamps.
    """

    def __init__(self, message: str, target_frame: str | None = None,
                 source_frame: str | None = None, edge: tuple[str | None, str] | None = None,
                 requested: float | None = None, earliest: float | None = None,
                 latest: float | None = None):
        super().__init__(message)
        self.target_frame = target_frame
        self.source_frame = source_frame
        self.edge = edge
        self.requested = requested
        self.earliest = earliest
        self.latest = latest


class PastExtrapolationException(ExtrapolationException):
    """Requested time is earlier than the oldest data on an edge."""


class FutureExtrapolationException(ExtrapolationException):
    """Requested time is later than the newest data on an edge."""


class InvalidArgumentException(TransformException, ValueError):
    """Malformed input: empty or '/'-prefixed frame id, parent == child, NaN/inf,
    a quaternion whose norm is off by more than 1 %, a non-finite time, or a
    parent change that would close a loop. Also a :class:`ValueError`."""


class TimeoutException(TransformException):
    """A lookup with ``timeout > 0`` did not become possible in time.

    The last underlying error is chained as ``__cause__`` and kept as ``last_error``.
    """

    def __init__(self, message: str, waited: float | None = None,
                 last_error: Exception | None = None):
        super().__init__(message)
        self.waited = waited
        self.last_error = last_error


__all__ = [
    "TransformException", "LookupException", "ConnectivityException",
    "ExtrapolationException", "PastExtrapolationException",
    "FutureExtrapolationException", "InvalidArgumentException", "TimeoutException",
]
