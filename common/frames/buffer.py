"""A time-aware transform buffer with tf2's names and semantics: the public API.

Built like tf2's BufferCore: each child frame's edge is a cache (:mod:`.time_cache`,
:mod:`.static_cache`), :mod:`.graph` walks the tree, and :class:`Buffer` adds the lock,
the waits and tf2's API. Lookups run on plain floats: a few microseconds for 3 hops.

Semantics (tf2's unless stated; the rules in detail are in the module named)
    * ``lookup_transform(target, source, t)`` maps data in ``source`` into ``target``;
      for one edge parent->child stored as (t, q), ``lookup_transform(parent, child)``
      is exactly (t, q). Translation interpolates linearly, rotation by shortest-path
      SLERP; a lookup at a stored stamp returns the stored sample exactly.
    * Static edges never expire and answer any time. :data:`LATEST` is the latest common
      time (:mod:`.graph`); a numeric 0.0 is a real sim time, not LATEST.
    * A dynamic edge keeps ``cache_time`` s back from its newest sample; an older insert
      is refused: set_transform returns False (TF_OLD_DATA) (:mod:`.time_cache`).
    * A new parent re-parents a child; switching static <-> dynamic replaces the edge.
    * A frame against itself is identity without any check of the id. Ids are validated
      target first, then source; a failed lookup reports what tf2's walkToTopParent
      reports (:mod:`.graph`). ``lookup_transform_full`` validates target, source and
      fixed frame, in that order, before any lookup.
    * ``clear()`` empties every dynamic edge and keeps static ones; every frame stays
      known, but an emptied edge has no parent until new data arrives (tf2 keeps the
      parent with each sample): a lookup through it raises ExtrapolationException naming
      only the emptied frame (ConnectivityException at LATEST); ``all_frames_as_string``
      shows NO_PARENT, ``all_frames_as_yaml`` and ``edge_stats`` leave it out.
    * Timeouts are wall seconds; a waiting call retries after every insert.

Deviations from tf2
    * A dynamic edge keeps one sample per stamp (the last inserted); tf2 keeps both.
    * Pruning is tf2's before release 0.37 (exactly cache_time kept); 0.37 and later
      keep one sample more for a moment.
    * Re-parenting drops the edge's history; tf2 keeps the parent per sample.
    * A parent change that would close a loop raises InvalidArgumentException naming the
      frames; tf2 stores it and its lookups fail.
    * A bad insert (empty or '/'-prefixed id, frame_id == child_frame_id, a non-finite
      stamp) raises InvalidArgumentException; tf2's setTransform logs it and returns
      False, and strips a leading '/' instead of refusing it.
    * A non-str frame id raises InvalidArgumentException, even for a frame to itself.
    * As 0.0 is a real time, a dynamic sample stamped 0.0 constrains LATEST; tf2 reads a
      zero stamp as "no time" there.
    * A dynamic edge's rate (edge_stats, all_frames_as_yaml) is (samples - 1) /
      buffer_length, the rate samples arrive at; tf2 prints samples / buffer_length.
    * Off the one sample of a dynamic edge a lookup raises Past/FutureExtrapolation-
      Exception; tf2 raises NoDataForExtrapolationException (an ExtrapolationException).

Thread safety: one lock guards it all, held by every insert and lookup throughout.
"""
from __future__ import annotations

import math
import threading
import time as _time
from typing import Any, Callable

from .arguments import check_cache_time, check_timeout, checked_insert
from .edge_stats import EdgeStats, frames_as_string, frames_as_yaml
from .errors import ExtrapolationException, TransformException
from .graph import FrameGraph
from .stamped import (LATEST, PointStamped, PoseStamped, TransformStamped, VectorStamped,
                      check_time, stamped_of, transformed)
from .static_cache import StaticCache
from .time_cache import TimeCache
from .waiting import Waits

_isfinite = math.isfinite


def _verdict(attempt: Callable[[], Any], debug: bool):
    """True if attempt() raises no TransformException; (ok, its message or "") if debug."""
    try:
        attempt()
    except TransformException as e:
        return (False, str(e)) if debug else False
    return (True, "") if debug else True


class Buffer:
    """tf2-style transform buffer (semantics: the module docstring). ``cache_time``: seconds
    of history each dynamic edge keeps; ``clock``: the wall clock (s) timeouts run on."""

    def __init__(self, cache_time: float = 10.0,
                 clock: Callable[[], float] = _time.monotonic) -> None:
        self._cache_time = check_cache_time(cache_time)
        self._lock = threading.Lock()
        self._graph = FrameGraph()
        self._edges = self._graph.edges     # read by every insert
        self._paths = self._graph.paths     # read by every lookup
        self._waits = Waits(self._lock, clock)

    @property
    def cache_time(self) -> float:
        """Length (s) of the window each dynamic edge keeps, back from its newest sample."""
        return self._cache_time

    @property
    def structure_version(self) -> int:
        """Incremented whenever the tree changes: an edge added, re-parented or replaced,
        or parents forgotten by clear()."""
        return self._graph.version

    @property
    def waiting(self) -> int:
        """How many calls are blocked now waiting for data (timeout > 0)."""
        return self._waits.waiting

    # ------------------------------------------------------------------ inserting
    def set_transform(self, ts: TransformStamped, authority: str = "default_authority") -> bool:
        """Insert a dynamic sample of the edge ts.frame_id -> ts.child_frame_id.

        Returns True if stored, False if older than the edge's window (newest -
        cache_time; tf2's TF_OLD_DATA), which is counted in ``edge_stats()``.
        Raises InvalidArgumentException for bad ids, parent == child, a non-finite
        stamp, or a parent change that would create a loop.
        """
        parent, child, stamp, v = checked_insert(ts, "set_transform")
        with self._lock:
            e = self._edges.get(child)
            if e is None or e.parent != parent or e.is_static:
                e = self._graph.attach(TimeCache(child, parent, self._cache_time, authority))
            if not e.insert(stamp, v, authority):
                return False
            if self._waits.waiting:
                self._waits.notify()
        return True

    def set_transform_static(self, ts: TransformStamped, authority: str = "default_authority") -> bool:
        """Set the static edge ts.frame_id -> ts.child_frame_id (valid at all times).
        Returns True; raises InvalidArgumentException like :meth:`set_transform`."""
        parent, child, stamp, v = checked_insert(ts, "set_transform_static")
        with self._lock:
            e = self._edges.get(child)
            if e is None or e.parent != parent or not e.is_static:
                e = self._graph.attach(StaticCache(child, parent, authority))
            e.insert(stamp, v, authority)
            if self._waits.waiting:
                self._waits.notify()
        return True

    # ------------------------------------------------------------------ lookups
    def lookup_transform(self, target_frame: str, source_frame: str, time: Any = LATEST,
                         timeout: float = 0.0) -> TransformStamped:
        """The transform mapping data in ``source_frame`` into ``target_frame`` at ``time``.

        Returns TransformStamped(frame_id=target_frame, child_frame_id=source_frame,
        stamp=time used (LATEST resolved), transform). With ``timeout > 0`` (wall
        seconds) waits for the data to arrive, then raises TimeoutException.
        """
        lock = self._lock
        if not timeout and type(time) is float and _isfinite(time):
            # hot path: explicit time and a cached path
            lock.acquire()
            try:
                try:
                    p = self._paths.get((target_frame, source_frame))
                except TypeError:  # unhashable frame id: resolve() says what is wrong
                    p = None
                if p is not None:
                    try:
                        v = p[3](time)
                    except ExtrapolationException as exc:
                        raise self._graph.walk_error(target_frame, source_frame, time, exc) from None
                else:
                    time, v = self._graph.resolve(target_frame, source_frame, time)
            finally:
                lock.release()
        elif not timeout and time is LATEST:
            with lock:
                time, v = self._graph.resolve(target_frame, source_frame, LATEST)
        else:
            time, v = self._resolve(target_frame, source_frame, time, timeout)
        return stamped_of(target_frame, source_frame, time, v)

    def _resolve(self, target: str, source: str, time: Any, timeout: Any,
                 fn: str = "lookupTransform") -> tuple[float, tuple]:
        """(stamp used, 7-tuple of target <- source), waiting up to ``timeout`` wall s."""
        if time is not LATEST:
            time = check_time(time)
        if timeout and check_timeout(timeout) > 0.0:
            return self._waits.until(
                lambda: self._graph.resolve(target, source, time, fn), float(timeout),
                f"transform from [{source}] to [{target}] at time "
                f"{time if time is LATEST else format(time, '.6f')}")
        with self._lock:
            return self._graph.resolve(target, source, time, fn)

    def lookup_transform_full(self, target_frame: str, target_time: Any, source_frame: str,
                              source_time: Any, fixed_frame: str,
                              timeout: float = 0.0) -> TransformStamped:
        """Time travel: data in ``source_frame`` at ``source_time`` into ``target_frame``
        at ``target_time``, assuming ``fixed_frame`` does not move:
        T(target@target_time <- fixed) * T(fixed <- source@source_time).
        The returned stamp is the (resolved) target_time, as in tf2."""
        target_time = check_time(target_time, "target_time")
        source_time = check_time(source_time, "source_time")
        timeout = check_timeout(timeout)
        args = (target_frame, target_time, source_frame, source_time, fixed_frame)
        if timeout > 0.0:
            t, v = self._waits.until(
                lambda: self._graph.resolve_full(*args), timeout,
                f"transform from [{source_frame}] at {source_time} to [{target_frame}] at "
                f"{target_time} via [{fixed_frame}]")
        else:
            with self._lock:
                t, v = self._graph.resolve_full(*args)
        return stamped_of(target_frame, source_frame, t, v)

    def can_transform(self, target_frame: str, source_frame: str, time: Any = LATEST,
                      timeout: float = 0.0, return_debug_tuple: bool = False):
        """True if lookup_transform would succeed (waiting up to ``timeout`` wall s).

        Never raises for lookup problems, including invalid arguments (tf2 returns
        false for those too). With ``return_debug_tuple`` returns (ok, reason), reason
        being "" on success or the error message.
        """
        return _verdict(lambda: self._resolve(target_frame, source_frame, time, timeout,
                                              "canTransform"), return_debug_tuple)

    def can_transform_full(self, target_frame: str, target_time: Any, source_frame: str,
                           source_time: Any, fixed_frame: str, timeout: float = 0.0,
                           return_debug_tuple: bool = False):
        """can_transform for :meth:`lookup_transform_full`."""
        return _verdict(lambda: self.lookup_transform_full(
            target_frame, target_time, source_frame, source_time, fixed_frame, timeout),
            return_debug_tuple)

    def get_latest_common_time(self, target_frame: str, source_frame: str) -> float:
        """What LATEST resolves to for this pair (0.0 if the chain is all static).
        Raises LookupException / ConnectivityException like a lookup."""
        with self._lock:
            return self._graph.latest_common_time(target_frame, source_frame)

    # ------------------------------------------------------------------ stamped data
    def transform_point(self, point: PointStamped, target_frame: str,
                        timeout: float = 0.0) -> PointStamped:
        """The point(s) in ``target_frame`` at the input's stamp."""
        return transformed(point, self.lookup_transform(target_frame, point.frame_id,
                                                        point.stamp, timeout))

    def transform_vector(self, vector: VectorStamped, target_frame: str,
                         timeout: float = 0.0) -> VectorStamped:
        """The vector(s) rotated into ``target_frame`` (translation ignored)."""
        return transformed(vector, self.lookup_transform(target_frame, vector.frame_id,
                                                         vector.stamp, timeout))

    def transform_pose(self, pose: PoseStamped, target_frame: str,
                       timeout: float = 0.0) -> PoseStamped:
        """The pose expressed in ``target_frame`` at the input's stamp."""
        return transformed(pose, self.lookup_transform(target_frame, pose.frame_id,
                                                       pose.stamp, timeout))

    # ------------------------------------------------------------------ introspection
    def frames(self) -> list[str]:
        """All known frame ids, sorted."""
        with self._lock:
            return sorted(self._graph.frames)

    def chain(self, target_frame: str, source_frame: str) -> list[str]:
        """Frames on the path from source_frame up to the common ancestor and down to
        target_frame (both ends included)."""
        with self._lock:
            return self._graph.chain(target_frame, source_frame)

    def edge_stats(self) -> dict[str, EdgeStats]:
        """Per child frame: its edge's parent, authority, rate, window, stamps (edges
        emptied by clear() have no parent and are left out)."""
        with self._lock:
            return {c: e.stats() for c, e in self._edges.items() if e.parent is not None}

    def all_frames_as_string(self) -> str:
        """tf2's listing: one "Frame X exists with parent Y." line per child frame."""
        with self._lock:
            return frames_as_string(self._edges.values())

    def all_frames_as_yaml(self, current_time: float | None = None) -> str:
        """tf2's allFramesAsYAML (see :func:`.edge_stats.frames_as_yaml`) of the edges with
        data; "[]" for an empty buffer, "" when clear() emptied every edge (as tf2)."""
        with self._lock:
            stats = [e.stats() for e in self._edges.values() if e.parent is not None]
            if not stats and self._edges:
                return ""
        return frames_as_yaml(stats, current_time)

    def clear(self) -> None:
        """Empty every dynamic edge, as tf2's clear() empties its time caches.

        Static edges keep their value and every frame stays known, but an emptied edge's
        parent is unknown until new data arrives (see the module docstring); a frame to
        itself is still identity.
        """
        with self._lock:
            self._graph.clear()

    def __repr__(self) -> str:
        return f"Buffer(cache_time={self._cache_time}, frames={len(self._graph.frames)})"


__all__ = ["Buffer", "EdgeStats"]
