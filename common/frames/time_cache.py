"""The samples of one dynamic edge parent -> child over time (tf2's TimeCache, cache.cpp).

Storage
    Parallel Python lists: ``stamps`` (sorted float seconds, searched with :mod:`bisect`),
    ``values`` (7-tuples (x, y, z, qx, qy, qz, qw) of the child's pose in the parent) and
    ``segs`` (SLERP constants of each segment between neighbouring samples, computed on
    insert so lookups skip the dot product, acos and one sin). Lookups read these lists
    directly (the evaluators :mod:`._pathcode` generates), so they stay plain attributes.

Window (tf2's rules unless stated)
    A cache keeps samples with ``stamp >= newest - cache_time``. An insert older than
    that is *not* stored: :meth:`TimeCache.insert` returns False and ``rejected_old``
    goes up (tf2 logs TF_OLD_DATA). Out-of-order inserts inside the window are placed in
    order; a duplicate stamp replaces the sample. Pruning is tf2's before release 0.37
    (ROS 2 Humble and Jazzy, ROS 1): insert, then drop what is older than the new newest
    stamp - cache_time, so the window is exactly cache_time long. tf2 0.37 and later
    prune against the previous newest stamp before inserting, so they briefly keep one
    sample more. Deviation: tf2 (every release) keeps two different samples with the
    same stamp; we keep the last one.

Parent
    tf2 stores the parent with every sample; here a cache has one parent (a new parent
    gets a new cache, see :mod:`.graph`). :meth:`TimeCache.clear` empties the samples,
    and with them the parent: an emptied cache's ``parent`` is None, as tf2 knows no
    parent for a frame whose cache is empty.
"""
from __future__ import annotations

import math
from bisect import bisect_left

from .edge_stats import EdgeStats
from .errors import (ExtrapolationException, FutureExtrapolationException,
                     PastExtrapolationException)
from .transform import SLERP_NLERP_DOT

#: SLERP constants of a segment not yet known (segs[0], or an insert before its neighbour).
NO_SEGMENT = (0.0, 1.0, 1.0)


def segment(a: tuple, b: tuple) -> tuple[float, float, float]:
    """SLERP constants for interpolating from sample a to sample b: (theta, 1/sin(theta),
    +-1/sin(theta)), the sign taking the short way round (q vs -q). Below the nlerp
    threshold theta is 0.0 and the last entry is just the sign."""
    d = a[3] * b[3] + a[4] * b[4] + a[5] * b[5] + a[6] * b[6]
    sign = 1.0
    if d < 0.0:
        d = -d
        sign = -1.0
    if d < SLERP_NLERP_DOT:
        th = math.acos(d)
        si = 1.0 / math.sin(th)
        return (th, si, sign * si)
    return (0.0, 1.0, sign)


def _fmt(t: float) -> str:
    return f"{t:.6f}"


class TimeCache:
    """The samples of the dynamic edge ``parent`` -> ``child``, ``window`` seconds long."""

    __slots__ = ("child", "parent", "window", "stamps", "values", "segs", "authority",
                 "inserts", "rejected_old")
    is_static = False

    def __init__(self, child: str, parent: str, window: float, authority: str) -> None:
        self.child = child
        self.parent: str | None = parent
        self.window = window
        self.stamps: list[float] = []
        self.values: list[tuple] = []
        # segs[i] = SLERP constants of the segment values[i-1] -> values[i] (segs[0] unused)
        self.segs: list[tuple] = []
        self.authority = authority
        self.inserts = 0
        self.rejected_old = 0

    def insert(self, stamp: float, v: tuple, authority: str) -> bool:
        """Store sample v (7-tuple) at stamp (s); False if older than the window."""
        stamps = self.stamps
        values = self.values
        segs = self.segs
        if not stamps or stamp > stamps[-1]:
            segs.append(segment(values[-1], v) if values else NO_SEGMENT)
            stamps.append(stamp)
            values.append(v)
            cutoff = stamp - self.window
            if stamps[0] < cutoff:
                k = bisect_left(stamps, cutoff)
                del stamps[:k]
                del values[:k]
                del segs[:k]
        else:
            if stamp < stamps[-1] - self.window:
                self.rejected_old += 1
                return False
            i = bisect_left(stamps, stamp)
            if stamps[i] == stamp:
                values[i] = v
            else:
                stamps.insert(i, stamp)
                values.insert(i, v)
                segs.insert(i, NO_SEGMENT)
            if i:
                segs[i] = segment(values[i - 1], v)
            if i + 1 < len(values):
                segs[i + 1] = segment(v, values[i + 1])
        self.authority = authority
        self.inserts += 1
        return True

    def clear(self) -> None:
        """Drop every sample, and so the parent (tf2's clearList)."""
        self.stamps.clear()
        self.values.clear()
        self.segs.clear()
        self.parent = None

    def latest(self) -> float:
        """The newest stamp, 0.0 when empty (tf2's getLatestTimestamp)."""
        return self.stamps[-1] if self.stamps else 0.0

    def check_at(self, t: float, target: str, source: str) -> ExtrapolationException | None:
        """The error sampling at t raises, or None if the samples cover t."""
        stamps = self.stamps
        if stamps and stamps[0] <= t <= stamps[-1]:
            return None
        return self.error_at(t, target, source)

    def error_at(self, t: float, target: str, source: str) -> ExtrapolationException:
        """The extrapolation error of sampling at t, which the samples do not cover, in a
        lookup of ``target`` <- ``source`` (both named, as tf2's messages do)."""
        stamps = self.stamps
        lookup = f"when looking up transform from frame [{source}] to frame [{target}]"
        if not stamps:
            # tf2's NoDataForExtrapolation: with no samples there is no parent to name either
            return ExtrapolationException(
                f"Lookup would require extrapolation at time {_fmt(t)}, but frame [{self.child}] "
                f"holds no data (cleared, so its parent is unknown), {lookup}.",
                target_frame=target, source_frame=source, edge=(None, self.child), requested=t)
        s0, s1 = stamps[0], stamps[-1]
        tail = (f", {lookup}. Edge [{self.parent}] -> [{self.child}] holds data from {_fmt(s0)} "
                f"to {_fmt(s1)} ({len(stamps)} samples).")
        facts = dict(target_frame=target, source_frame=source, edge=(self.parent, self.child),
                     requested=t, earliest=s0, latest=s1)
        if t < s0:
            return PastExtrapolationException(
                f"Lookup would require extrapolation into the past. Requested time {_fmt(t)} "
                f"but the earliest data is at time {_fmt(s0)}" + tail, **facts)
        return FutureExtrapolationException(
            f"Lookup would require extrapolation into the future. Requested time {_fmt(t)} "
            f"but the latest data is at time {_fmt(s1)}" + tail, **facts)

    def stats(self) -> EdgeStats:
        """This edge's :class:`EdgeStats` (parent known: the cache holds samples)."""
        st = self.stamps
        n = len(st)
        span = st[-1] - st[0] if n else 0.0
        rate = (n - 1) / span if n > 1 and span > 0.0 else 0.0
        return EdgeStats(self.child, self.parent, self.authority, False, rate, span,
                         st[-1] if n else 0.0, st[0] if n else 0.0, n, self.inserts,
                         self.rejected_old)


__all__ = ["TimeCache", "segment", "NO_SEGMENT"]
