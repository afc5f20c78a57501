"""A time-aware transform buffer with tf2's names and semantics.

Storage
    The frames form a forest: every child frame has at most one parent edge.
    A dynamic edge keeps parallel Python lists ``stamps`` (sorted floats, searched
    with :mod:`bisect`), ``values`` (7-tuples of floats) and ``segs`` (SLERP
    constants of each segment between neighbouring samples, computed on insert); a
    static edge keeps a single 7-tuple. Lookups do plain-float math and build one
    :class:`Transform` at the end, so an interpolated 3-hop lookup costs a few
    microseconds. Frame paths are cached per ``(target, source)`` together with a
    straight-line evaluator generated for the path's shape (:mod:`._pathcode`); the
    cache is dropped whenever the tree changes (``structure_version`` counts those
    changes).

Semantics (tf2's unless stated)
    * ``lookup_transform(target, source, t)`` maps data expressed in ``source`` into
      ``target``. For one edge parent->child stored as (t, q), ``lookup_transform(
      parent, child)`` is exactly (t, q).
    * Translation interpolates linearly, rotation by shortest-path SLERP; a lookup
      at a stored stamp returns the stored sample exactly.
    * Static edges never expire and answer any time. :data:`LATEST` is the latest
      common time: the minimum over the chain's dynamic edges of each edge's newest
      stamp. Static edges do not constrain it; a chain with no dynamic edge answers
      LATEST with stamp 0.0 (tf2's Time(0)). For a frame to itself LATEST is that
      frame's own newest stamp (see below). A numeric 0.0 is a real sim time, not LATEST.
    * A dynamic edge keeps samples with ``stamp >= newest - cache_time``. An insert
      older than that is *not* stored: ``set_transform`` returns False and the edge's
      ``rejected_old`` counter goes up (tf2 logs TF_OLD_DATA). Out-of-order inserts
      inside the window are placed in order; a duplicate stamp replaces the sample.
      Pruning is tf2's before release 0.37 (ROS 2 Humble and Jazzy, ROS 1): insert,
      then drop what is older than the new newest stamp - cache_time, so the window is
      exactly cache_time long. tf2 0.37 and later prune against the previous newest
      stamp before inserting, so they briefly keep one sample more. Deviation: tf2 (every
      release) keeps two different samples with the same stamp; we keep the last one.
    * Giving a child a new parent re-parents it (tf2 allows this). Unlike tf2, which
      keeps the parent per sample, the edge's old history is dropped, since samples
      relative to different parents cannot be interpolated. A parent change that
      would close a loop raises InvalidArgumentException naming the frames.
      Likewise switching an edge between static and dynamic replaces it.
    * A frame looked up against itself is identity without any check of the id (even
      unknown or empty), stamped with the requested time, or for LATEST the frame's own
      newest stamp (0.0 if static, a root or unknown); ``can_transform(x, x)`` is True.
      (tf2's lookupTransformImpl / canTransform short-circuit.) Deviation: a non-str id
      still raises InvalidArgumentException; tf2's ids are always strings.
    * Where a lookup at a numeric time fails, the error is the one tf2's walkToTopParent
      reports: it walks up from the source until the root or the first edge without data
      (remembering that edge's extrapolation), then up from the target; an edge without
      data on that side is reported at once; reaching the target's root reports the
      source side's extrapolation if there was one, else ConnectivityException. So frames
      in different trees give an ExtrapolationException when an edge walked has no data
      at that time, and with failures on both sides the target side's edge is named. At
      LATEST different trees are a ConnectivityException (tf2's getLatestCommonTime).
    * ``lookup_transform_full`` validates target, source and fixed frame (in that order)
      before any lookup, as tf2 does.
    * ``clear()`` empties every dynamic edge and keeps static ones, and every frame stays
      known with its parent (tf2 clears its time caches but not its frame table): through
      an emptied edge a numeric-time lookup raises ExtrapolationException (no data) and
      LATEST a ConnectivityException; ``all_frames_as_string`` shows the emptied frame's
      parent as NO_PARENT and ``all_frames_as_yaml`` leaves it out, as tf2's do.
    * Timeouts are wall seconds (tf2's semantics); waiting blocks on a
      :class:`threading.Condition` that every insert notifies.

Thread safety
    One lock guards the whole structure; every insert and every lookup holds it for
    its whole duration, so a reader never sees a half-inserted edge. Designed for one
    writer and many readers (any number of writers is also safe).
"""
from __future__ import annotations

import math
import threading
import time as _time
from bisect import bisect_left
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .errors import (ConnectivityException, ExtrapolationException,
                     FutureExtrapolationException, InvalidArgumentException,
                     LookupException, PastExtrapolationException, TimeoutException,
                     TransformException)
from . import _pathcode
from .stamped import (LATEST, PointStamped, PoseStamped, TransformStamped, VectorStamped,
                      check_time)
from .transform import IDENTITY7, SLERP_NLERP_DOT, Transform, _compose

_isfinite = math.isfinite
_monotonic = _time.monotonic
_new = object.__new__
_setattr = object.__setattr__
_Transform_of = Transform._of

_WAITABLE = (LookupException, ConnectivityException, ExtrapolationException)
_MAX_DEPTH = 100_000
_PATH_CACHE_MAX = 4096


@dataclass(frozen=True)
class EdgeStats:
    """Bookkeeping of one edge parent -> child (what tf2's allFramesAsYAML reports, and more).

    ``rate_hz`` is (samples - 1) / buffer_length (0.0 for static edges or a single
    sample); ``buffer_length`` = most_recent - oldest (s). For a static edge
    ``most_recent`` and ``oldest`` are the stamp it was published with.
    ``rejected_old`` counts inserts refused as older than the window (TF_OLD_DATA).
    """

    child: str
    parent: str
    authority: str
    is_static: bool
    rate_hz: float
    buffer_length: float
    most_recent: float
    oldest: float
    samples: int
    inserts: int
    rejected_old: int


class _Edge:
    __slots__ = ("child", "parent", "stamps", "values", "segs", "value", "authority",
                 "inserts", "rejected_old", "static_stamp")

    def __init__(self, child: str, parent: str, static: bool, authority: str) -> None:
        self.child = child
        self.parent = parent
        self.stamps: list[float] | None = None if static else []
        self.values: list[tuple] | None = None if static else []
        # segs[i] = SLERP constants of the segment values[i-1] -> values[i] (see _segment);
        # segs[0] is unused. Kept parallel to stamps/values.
        self.segs: list[tuple] | None = None if static else []
        self.value: tuple = IDENTITY7
        self.authority = authority
        self.inserts = 0
        self.rejected_old = 0
        self.static_stamp = 0.0

    @property
    def static(self) -> bool:
        return self.stamps is None


def _fmt(t: float) -> str:
    return f"{t:.6f}"


def _extrapolation(e: _Edge, t: float, target: str, source: str) -> ExtrapolationException:
    stamps = e.stamps
    if not stamps:   # an edge emptied by clear(): tf2 reports an extrapolation with no data
        return ExtrapolationException(
            f"Lookup would require extrapolation at time {_fmt(t)}, but edge [{e.parent}] -> "
            f"[{e.child}] holds no data (cleared) when looking up transform from frame "
            f"[{source}] to frame [{target}].",
            target_frame=target, source_frame=source, edge=(e.parent, e.child), requested=t)
    s0, s1 = stamps[0], stamps[-1]
    tail = (f" when looking up transform from frame [{source}] to frame [{target}]. "
            f"Edge [{e.parent}] -> [{e.child}] holds data from {_fmt(s0)} to {_fmt(s1)} "
            f"({len(stamps)} samples).")
    if t < s0:
        return PastExtrapolationException(
            f"Lookup would require extrapolation into the past. Requested time {_fmt(t)} "
            f"but the earliest data is at time {_fmt(s0)}," + tail,
            target_frame=target, source_frame=source, edge=(e.parent, e.child),
            requested=t, earliest=s0, latest=s1)
    return FutureExtrapolationException(
        f"Lookup would require extrapolation into the future. Requested time {_fmt(t)} "
        f"but the latest data is at time {_fmt(s1)}," + tail,
        target_frame=target, source_frame=source, edge=(e.parent, e.child),
        requested=t, earliest=s0, latest=s1)


_NO_SEGMENT = (0.0, 1.0, 1.0)


def _edge_error(e: _Edge, t: float, target: str, source: str) -> ExtrapolationException | None:
    """The error sampling edge e at time t would raise, or None if it has data there."""
    stamps = e.stamps
    if stamps is None or (stamps and stamps[0] <= t <= stamps[-1]):
        return None
    return _extrapolation(e, t, target, source)


def _not_connected(target: str, source: str, target_root: str, source_root: str) -> ConnectivityException:
    return ConnectivityException(
        f"Could not find a connection between '{target}' and '{source}' because they are not "
        f"part of the same tree. Tf has two or more unconnected trees. ('{target}' is in the "
        f"tree rooted at '{target_root}', '{source}' in the tree rooted at '{source_root}'.)",
        target_frame=target, source_frame=source)


def _walk_error(edges: dict, target: str, source: str, t: float,
                fallback: TransformException) -> TransformException:
    """The error tf2's walkToTopParent reports for a failed lookup at time t (lock held).

    tf2 walks up from the source until the root or the first edge without data at t
    (remembering that edge's error), then up from the target until it meets the frame
    where the source walk stopped: an edge without data there is reported at once;
    reaching the target's root instead reports the source side's extrapolation if
    there was one, else that the frames are not connected. `fallback` is returned if
    the walk finds nothing wrong (it cannot when the caller's lookup failed).
    """
    src_err = None
    f = source
    while f in edges and f != target:
        e = edges[f]
        src_err = _edge_error(e, t, target, source)
        if src_err is not None:
            break
        f = e.parent
    top = f
    g = target
    while g != top and g != source:
        e = edges.get(g)
        if e is None:
            break
        err = _edge_error(e, t, target, source)
        if err is not None:
            return err
        g = e.parent
    if g == top or g == source:
        return fallback
    if src_err is not None:
        return src_err
    return _not_connected(target, source, g, top)


def _segment(a: tuple, b: tuple) -> tuple[float, float, float]:
    """SLERP constants for interpolating from sample a to sample b, computed on insert
    so lookups skip the dot product, acos and one sin: (theta, 1/sin(theta),
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


def _identity_ev(t: float) -> tuple:
    return IDENTITY7


def _check_frame_id(frame: Any, what: str) -> None:
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


def _check_timeout(timeout: Any) -> float:
    try:
        t = float(timeout)
    except (TypeError, ValueError) as e:
        raise InvalidArgumentException(f"timeout must be a number of seconds, got {timeout!r}") from e
    if not (_isfinite(t) and t >= 0.0):
        raise InvalidArgumentException(f"timeout must be finite and >= 0, got {timeout!r}")
    return t


class Buffer:
    """tf2-style transform buffer. See the module docstring for the semantics."""

    def __init__(self, cache_time: float = 10.0) -> None:
        try:
            ct = float(cache_time)
        except (TypeError, ValueError) as e:
            raise InvalidArgumentException(f"cache_time must be seconds, got {cache_time!r}") from e
        if not (_isfinite(ct) and ct > 0.0):
            raise InvalidArgumentException(f"cache_time must be finite and > 0, got {cache_time!r}")
        self._cache_time = ct
        self._lock = threading.Lock()
        self._cond = threading.Condition(self._lock)
        self._waiting = 0
        self._edges: dict[str, _Edge] = {}
        self._frames: dict[str, None] = {}  # insertion-ordered set of known frame ids
        self._paths: dict[tuple[str, str], tuple] = {}
        self._version = 0

    # ------------------------------------------------------------------ properties
    @property
    def cache_time(self) -> float:
        """Length (s) of the window each dynamic edge keeps, back from its newest sample."""
        return self._cache_time

    @property
    def structure_version(self) -> int:
        """Incremented whenever an edge is added, re-parented, replaced or removed."""
        return self._version

    # ------------------------------------------------------------------ inserting
    def _validate_ts(self, ts: TransformStamped, fn: str) -> tuple[str, str, float, tuple]:
        parent = ts.frame_id
        child = ts.child_frame_id
        stamp = ts.stamp
        tr = ts.transform
        if type(parent) is not str or not parent or parent[0] == "/":
            _check_frame_id(parent, f"{fn} frame_id")
        if type(child) is not str or not child or child[0] == "/":
            _check_frame_id(child, f"{fn} child_frame_id")
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

    def _replace_edge(self, child: str, parent: str, static: bool, authority: str) -> _Edge:
        """New edge for `child` under `parent` (lock held). Refuses loops."""
        old = self._edges.get(child)
        if old is None or old.parent != parent:
            f = parent
            depth = 0
            edges = self._edges
            while f in edges:
                f = edges[f].parent
                depth += 1
                if f == child or depth > _MAX_DEPTH:
                    raise InvalidArgumentException(
                        f"Refusing to make \"{parent}\" the parent of \"{child}\": \"{child}\" is "
                        f"already an ancestor of \"{parent}\", so the tree would contain a loop "
                        f"({child} -> ... -> {parent} -> {child})")
        e = _Edge(child, parent, static, authority)
        self._edges[child] = e
        self._frames.setdefault(parent, None)
        self._frames.setdefault(child, None)
        self._paths.clear()
        self._version += 1
        return e

    def set_transform(self, ts: TransformStamped, authority: str = "default_authority") -> bool:
        """Insert a dynamic sample of the edge ts.frame_id -> ts.child_frame_id.

        Returns True if stored, False if older than the edge's window (newest -
        cache_time; tf2's TF_OLD_DATA), which is counted in ``edge_stats()``.
        Raises InvalidArgumentException for bad ids, parent == child, a non-finite
        stamp, or a parent change that would create a loop.
        """
        parent, child, stamp, v = self._validate_ts(ts, "set_transform")
        with self._lock:
            e = self._edges.get(child)
            if e is None or e.parent != parent or e.stamps is None:
                e = self._replace_edge(child, parent, False, authority)
            stamps = e.stamps
            values = e.values
            segs = e.segs
            if not stamps or stamp > stamps[-1]:
                segs.append(_segment(values[-1], v) if values else _NO_SEGMENT)
                stamps.append(stamp)
                values.append(v)
                cutoff = stamp - self._cache_time
                if stamps[0] < cutoff:
                    k = bisect_left(stamps, cutoff)
                    del stamps[:k]
                    del values[:k]
                    del segs[:k]
            else:
                if stamp < stamps[-1] - self._cache_time:
                    e.rejected_old += 1
                    return False
                i = bisect_left(stamps, stamp)
                if stamps[i] == stamp:
                    values[i] = v
                else:
                    stamps.insert(i, stamp)
                    values.insert(i, v)
                    segs.insert(i, _NO_SEGMENT)
                if i:
                    segs[i] = _segment(values[i - 1], v)
                if i + 1 < len(values):
                    segs[i + 1] = _segment(v, values[i + 1])
            e.authority = authority
            e.inserts += 1
            if self._waiting:
                self._cond.notify_all()
        return True

    def set_transform_static(self, ts: TransformStamped, authority: str = "default_authority") -> bool:
        """Set the static edge ts.frame_id -> ts.child_frame_id (valid at all times).

        Returns True; raises InvalidArgumentException like :meth:`set_transform`.
        """
        parent, child, stamp, v = self._validate_ts(ts, "set_transform_static")
        with self._lock:
            e = self._edges.get(child)
            if e is None or e.parent != parent or e.stamps is not None:
                e = self._replace_edge(child, parent, True, authority)
            e.value = v
            e.static_stamp = stamp
            e.authority = authority
            e.inserts += 1
            if self._waiting:
                self._cond.notify_all()
        return True

    # ------------------------------------------------------------------ paths
    def _path(self, target: str, source: str, fn: str) -> tuple:
        """(source edges up to the common ancestor, target edges likewise, the dynamic
        edges among them, the compiled evaluator or None for a frame to itself).
        Lock held."""
        _check_frame_id(target, f"{fn} argument target_frame")
        _check_frame_id(source, f"{fn} argument source_frame")
        key = (target, source)
        p = self._paths.get(key)
        if p is not None:
            return p
        frames = self._frames
        if target not in frames:
            raise LookupException(
                f"\"{target}\" passed to {fn} argument target_frame does not exist. ",
                frame=target, argument="target_frame")
        if source not in frames:
            raise LookupException(
                f"\"{source}\" passed to {fn} argument source_frame does not exist. ",
                frame=source, argument="source_frame")
        edges = self._edges
        if target == source:
            e = edges.get(source)
            p = ((), (), (e,) if e is not None and e.stamps is not None else (), _identity_ev)
        else:
            up: dict[str, int] = {source: 0}
            chain_s: list[_Edge] = []
            f = source
            while f in edges:
                e = edges[f]
                chain_s.append(e)
                f = e.parent
                up[f] = len(chain_s)
            chain_t: list[_Edge] = []
            f = target
            while f not in up:
                e = edges.get(f)
                if e is None:
                    raise _not_connected(target, source, f,
                                         chain_s[-1].parent if chain_s else source)
                chain_t.append(e)
                f = e.parent
            chain_s = chain_s[:up[f]]
            dyn = tuple(e for e in chain_s + chain_t if e.stamps is not None)
            src_t, tgt_t = tuple(chain_s), tuple(chain_t)
            make = _pathcode.factory(tuple(e.stamps is None for e in chain_s),
                                     tuple(e.stamps is None for e in chain_t), _extrapolation)
            ev = make(*chain_s, *chain_t, target, source)
            p = (src_t, tgt_t, dyn, ev)
        if len(self._paths) >= _PATH_CACHE_MAX:
            self._paths.clear()
        self._paths[key] = p
        return p

    # ------------------------------------------------------------------ core lookup
    def _own_latest(self, frame: str) -> float:
        """LATEST for a frame to itself: its own newest stamp, 0.0 if static, a root,
        emptied by clear() or unknown (tf2's getLatestTimestamp of its cache). Lock held."""
        e = self._edges.get(frame)
        return e.stamps[-1] if e is not None and e.stamps else 0.0

    def _lookup_locked(self, target: str, source: str, time: Any,
                       fn: str = "lookupTransform") -> tuple[float, tuple]:
        """(stamp used, 7-tuple of target <- source). Lock held."""
        if target == source and type(target) is str:
            # tf2: identity without validating the id (even unknown or empty); stamp = the
            # requested time, or for LATEST the frame's own newest stamp
            return (self._own_latest(target) if time is LATEST else time), IDENTITY7
        try:
            p = self._paths.get((target, source))
        except TypeError:  # unhashable frame id
            p = None
        if p is None:
            try:
                p = self._path(target, source, fn)
            except ConnectivityException as exc:
                if time is LATEST:
                    raise   # tf2's getLatestCommonTime: different trees are a connectivity error
                raise _walk_error(self._edges, target, source, time, exc) from None
        src, tgt, dyn, ev = p
        if time is LATEST:
            t = 0.0
            if dyn:
                t = math.inf
                for e in dyn:
                    st = e.stamps
                    if not st:   # emptied by clear(): at LATEST tf2 finds no parent here
                        raise _not_connected(target, source, e.child if e in tgt else target,
                                             e.child if e in src else source)
                    if st[-1] < t:
                        t = st[-1]
        else:
            t = time
        try:
            return t, ev(t)
        except ExtrapolationException as exc:
            raise _walk_error(self._edges, target, source, t, exc) from None

    def _wait(self, attempt: Callable[[], Any], timeout: float, what: str) -> Any:
        """Retry `attempt` (lock held) each time the buffer changes, until `timeout` wall s."""
        deadline = _monotonic() + timeout
        with self._cond:
            self._waiting += 1
            try:
                while True:
                    try:
                        return attempt()
                    except _WAITABLE as e:
                        last = e
                    remaining = deadline - _monotonic()
                    if remaining <= 0.0:
                        raise TimeoutException(
                            f"Timed out after {timeout:.3f} s (wall) waiting for {what}. "
                            f"Last error: {last}", waited=timeout, last_error=last) from last
                    self._cond.wait(remaining)
            finally:
                self._waiting -= 1

    # ------------------------------------------------------------------ public lookups
    def lookup_transform(self, target_frame: str, source_frame: str, time: Any = LATEST,
                         timeout: float = 0.0) -> TransformStamped:
        """The transform mapping data in ``source_frame`` into ``target_frame`` at ``time``.

        Returns TransformStamped(frame_id=target_frame, child_frame_id=source_frame,
        stamp=time used (LATEST resolved), transform). With ``timeout > 0`` (wall
        seconds) waits for the data to arrive, then raises TimeoutException.
        """
        if timeout:
            timeout = _check_timeout(timeout)
            if timeout > 0.0:
                if time is not LATEST:
                    time = check_time(time)
                t, v = self._wait(
                    lambda: self._lookup_locked(target_frame, source_frame, time),
                    timeout, f"transform from [{source_frame}] to [{target_frame}] at time "
                             f"{time if time is LATEST else _fmt(time)}")
                return _stamped(target_frame, source_frame, t, v)
        lock = self._lock
        if type(time) is float and _isfinite(time):
            # hot path: explicit time and a cached path; everything else goes the long way
            lock.acquire()
            try:
                try:
                    p = self._paths.get((target_frame, source_frame))
                except TypeError:  # unhashable frame id: let _path say what is wrong
                    p = None
                if p is not None:
                    try:
                        v = p[3](time)
                    except ExtrapolationException as exc:
                        raise _walk_error(self._edges, target_frame, source_frame, time, exc) from None
                else:
                    time, v = self._lookup_locked(target_frame, source_frame, time)
            finally:
                lock.release()
        else:
            if time is not LATEST:
                time = check_time(time)
            lock.acquire()
            try:
                time, v = self._lookup_locked(target_frame, source_frame, time)
            finally:
                lock.release()
        return _stamped(target_frame, source_frame, time, v)

    def _full_locked(self, target: str, target_time: Any, source: str, source_time: Any,
                     fixed: str) -> tuple[float, tuple]:
        # tf2 validates all three ids before any lookup
        for frame, arg in ((target, "target_frame"), (source, "source_frame"), (fixed, "fixed_frame")):
            _check_frame_id(frame, f"lookupTransform argument {arg}")
            if frame not in self._frames:
                raise LookupException(
                    f"\"{frame}\" passed to lookupTransform argument {arg} does not exist. ",
                    frame=frame, argument=arg)
        _, a = self._lookup_locked(fixed, source, source_time)
        t, b = self._lookup_locked(target, fixed, target_time)
        return t, _compose(b, a)

    def lookup_transform_full(self, target_frame: str, target_time: Any, source_frame: str,
                              source_time: Any, fixed_frame: str,
                              timeout: float = 0.0) -> TransformStamped:
        """Time travel: data in ``source_frame`` at ``source_time`` into ``target_frame``
        at ``target_time``, assuming ``fixed_frame`` does not move:
        T(target@target_time <- fixed) * T(fixed <- source@source_time).
        The returned stamp is the (resolved) target_time, as in tf2."""
        target_time = check_time(target_time, "target_time")
        source_time = check_time(source_time, "source_time")
        timeout = _check_timeout(timeout)

        def attempt():
            return self._full_locked(target_frame, target_time, source_frame, source_time,
                                     fixed_frame)

        if timeout > 0.0:
            t, v = self._wait(attempt, timeout,
                              f"transform from [{source_frame}] at {source_time} to "
                              f"[{target_frame}] at {target_time} via [{fixed_frame}]")
        else:
            with self._lock:
                t, v = attempt()
        return TransformStamped(target_frame, source_frame, t, _Transform_of(v))

    def can_transform(self, target_frame: str, source_frame: str, time: Any = LATEST,
                      timeout: float = 0.0, return_debug_tuple: bool = False):
        """True if lookup_transform would succeed (waiting up to ``timeout`` wall s).

        Never raises for lookup problems, including invalid arguments (tf2 returns
        false for those too). With ``return_debug_tuple`` returns (ok, reason), reason
        being "" on success or the error message.
        """
        try:
            time = check_time(time)
            timeout = _check_timeout(timeout)
            if timeout > 0.0:
                self._wait(lambda: self._lookup_locked(target_frame, source_frame, time,
                                                       "canTransform"),
                           timeout, f"transform from [{source_frame}] to [{target_frame}]")
            else:
                with self._lock:
                    self._lookup_locked(target_frame, source_frame, time, "canTransform")
        except TransformException as e:
            return (False, str(e)) if return_debug_tuple else False
        return (True, "") if return_debug_tuple else True

    def can_transform_full(self, target_frame: str, target_time: Any, source_frame: str,
                           source_time: Any, fixed_frame: str, timeout: float = 0.0,
                           return_debug_tuple: bool = False):
        """can_transform for :meth:`lookup_transform_full`."""
        try:
            self.lookup_transform_full(target_frame, target_time, source_frame, source_time,
                                       fixed_frame, timeout)
        except TransformException as e:
            return (False, str(e)) if return_debug_tuple else False
        return (True, "") if return_debug_tuple else True

    def get_latest_common_time(self, target_frame: str, source_frame: str) -> float:
        """What LATEST resolves to for this pair (0.0 if the chain is all static).
        Raises LookupException / ConnectivityException like a lookup."""
        with self._lock:
            src, tgt, dyn, _ = self._path(target_frame, source_frame, "getLatestCommonTime")
            if target_frame == source_frame:
                return self._own_latest(source_frame)
            for e in dyn:
                if not e.stamps:
                    raise _not_connected(target_frame, source_frame,
                                         e.child if e in tgt else target_frame,
                                         e.child if e in src else source_frame)
            return min((e.stamps[-1] for e in dyn), default=0.0)

    # ------------------------------------------------------------------ stamped helpers
    def transform_point(self, point: PointStamped, target_frame: str,
                        timeout: float = 0.0) -> PointStamped:
        """The point(s) in ``target_frame`` at the input's stamp."""
        ts = self.lookup_transform(target_frame, point.frame_id, point.stamp, timeout)
        return _make(PointStamped, frame_id=target_frame, stamp=ts.stamp,
                     point=_ro(ts.transform.apply_point(point.point)))

    def transform_vector(self, vector: VectorStamped, target_frame: str,
                         timeout: float = 0.0) -> VectorStamped:
        """The vector(s) rotated into ``target_frame`` (translation ignored)."""
        ts = self.lookup_transform(target_frame, vector.frame_id, vector.stamp, timeout)
        return _make(VectorStamped, frame_id=target_frame, stamp=ts.stamp,
                     vector=_ro(ts.transform.apply_vector(vector.vector)))

    def transform_pose(self, pose: PoseStamped, target_frame: str,
                       timeout: float = 0.0) -> PoseStamped:
        """The pose expressed in ``target_frame`` at the input's stamp."""
        ts = self.lookup_transform(target_frame, pose.frame_id, pose.stamp, timeout)
        v = _compose(ts.transform.to_tuple(), pose.as_transform().to_tuple())
        return _make(PoseStamped, frame_id=target_frame, stamp=ts.stamp,
                     position=_ro(np.array(v[:3])), orientation=_ro(np.array(v[3:])))

    # ------------------------------------------------------------------ introspection
    def frames(self) -> list[str]:
        """All known frame ids, sorted."""
        with self._lock:
            return sorted(self._frames)

    def chain(self, target_frame: str, source_frame: str) -> list[str]:
        """Frames on the path from source_frame up to the common ancestor and down to
        target_frame (both ends included)."""
        with self._lock:
            src, tgt, _, _ = self._path(target_frame, source_frame, "chain")
            down = [e.child for e in tgt][::-1]
            if not src and not tgt:
                return [source_frame]
            up = [e.child for e in src] + [(src[-1].parent if src else tgt[-1].parent)]
            return up + down

    def _stats(self, e: _Edge) -> EdgeStats:
        if e.stamps is None:
            return EdgeStats(e.child, e.parent, e.authority, True, 0.0, 0.0,
                             e.static_stamp, e.static_stamp, 1, e.inserts, e.rejected_old)
        st = e.stamps
        n = len(st)
        span = st[-1] - st[0] if n else 0.0
        rate = (n - 1) / span if n > 1 and span > 0.0 else 0.0
        return EdgeStats(e.child, e.parent, e.authority, False, rate, span,
                         st[-1] if n else 0.0, st[0] if n else 0.0, n, e.inserts, e.rejected_old)

    def edge_stats(self) -> dict[str, EdgeStats]:
        """Per child frame: its edge's parent, authority, rate, window, stamps."""
        with self._lock:
            return {c: self._stats(e) for c, e in self._edges.items()}

    def all_frames_as_string(self) -> str:
        """tf2's listing: one "Frame X exists with parent Y." line per child frame."""
        with self._lock:
            # an edge emptied by clear() has no parent to show (tf2 prints NO_PARENT)
            return "".join(f"Frame {c} exists with parent "
                           f"{e.parent if e.stamps is None or e.stamps else 'NO_PARENT'}.\n"
                           for c, e in self._edges.items())

    def all_frames_as_yaml(self, current_time: float | None = None) -> str:
        """tf2's allFramesAsYAML: per child frame its parent, broadcaster, rate,
        most_recent_transform, oldest_transform, (transform_delay if current_time is
        given) and buffer_length, 3 decimals. Static edges read like tf2's: rate
        10000.000 and stamps 0.000. An empty buffer gives "[]"."""
        with self._lock:   # tf2 leaves out edges emptied by clear()
            stats = [self._stats(e) for e in self._edges.values() if e.stamps is None or e.stamps]
        if not stats:
            return "[]"
        out = []
        for s in stats:
            if s.is_static:
                rate, recent, oldest, length = 10000.0, 0.0, 0.0, 0.0
            else:
                rate, recent, oldest, length = s.rate_hz, s.most_recent, s.oldest, s.buffer_length
            out.append(f"{s.child}: \n")
            out.append(f"  parent: '{s.parent}'\n")
            out.append(f"  broadcaster: '{s.authority}'\n")
            out.append(f"  rate: {rate:.3f}\n")
            out.append(f"  most_recent_transform: {recent:.3f}\n")
            out.append(f"  oldest_transform: {oldest:.3f}\n")
            if current_time is not None and current_time > 0:
                out.append(f"  transform_delay: {current_time - recent:.3f}\n")
            out.append(f"  buffer_length: {length:.3f}\n")
        return "".join(out)

    def clear(self) -> None:
        """Empty every dynamic edge, as tf2's clear() empties its time caches.

        Static edges keep their value, and every frame stays known with its parent: a
        lookup through an emptied edge raises ExtrapolationException at a numeric time and
        ConnectivityException at LATEST, and a frame to itself is still identity (tf2).
        The tree's structure is unchanged, so structure_version is too.
        """
        with self._lock:
            for e in self._edges.values():
                if e.stamps is not None:
                    e.stamps.clear()
                    e.values.clear()
                    e.segs.clear()

    def __repr__(self) -> str:
        return f"Buffer(cache_time={self._cache_time}, frames={len(self._frames)})"


_set_v = Transform.__dict__["_v"].__set__
_set_frame_id = TransformStamped.__dict__["frame_id"].__set__
_set_child_frame_id = TransformStamped.__dict__["child_frame_id"].__set__
_set_stamp = TransformStamped.__dict__["stamp"].__set__
_set_transform = TransformStamped.__dict__["transform"].__set__


def _stamped(target: str, source: str, t: float, v: tuple) -> TransformStamped:
    """TransformStamped(target, source, t, Transform(v)) without re-validating (hot path)."""
    tr = _new(Transform)
    _set_v(tr, v)
    ts = _new(TransformStamped)
    _set_frame_id(ts, target)
    _set_child_frame_id(ts, source)
    _set_stamp(ts, t)
    _set_transform(ts, tr)
    return ts


def _ro(a):
    a.flags.writeable = False
    return a


def _make(cls, **fields):
    """Build a frozen stamped value from already-validated fields (no copies)."""
    obj = _new(cls)
    for k, val in fields.items():
        _setattr(obj, k, val)
    return obj


__all__ = ["Buffer", "EdgeStats"]
