"""The frame tree and the walk over it (tf2's BufferCore: walkToTopParent, getLatestCommonTime).

The frames form a forest: every child frame has at most one parent edge, a cache of its
samples (:class:`.TimeCache`) or its one value (:class:`.StaticCache`). A lookup of
``target`` <- ``source`` walks up from the source to the common ancestor and up from the
target to it; the edges found are kept per ``(target, source)`` together with a
straight-line evaluator generated for the path's shape (:mod:`._pathcode`), so a repeated
lookup only evaluates. Any change of the tree drops those paths and counts in ``version``.

Rules (tf2's unless stated)
    * Ids are validated target first, then source: an empty or '/'-prefixed id is an
      InvalidArgumentException, an unknown one a LookupException (validateFrameId).
    * A frame looked up against itself is identity without any check of the id, stamped
      with the requested time, or for LATEST that frame's own newest stamp (0.0 if
      static, a root, emptied or unknown) (lookupTransformImpl's short-circuit).
    * LATEST is the latest common time: the minimum over the path's dynamic edges of each
      edge's newest stamp; static edges do not constrain it; an all-static path gives 0.0.
      Frames in different trees are a ConnectivityException (getLatestCommonTime).
    * A lookup at a numeric time that fails reports what walkToTopParent reports: it walks
      up from the source until the root or the first edge without data at that time
      (remembering that edge's error), then up from the target until it meets that frame;
      an edge without data on the target side is reported at once; reaching the target's
      root reports the source side's error if there was one, else ConnectivityException.
    * An edge emptied by clear() has no parent (tf2 keeps the parent with each sample):
      the walks stop there, and its error names no parent.
    * Deviation: a parent change that would close a loop is refused with
      InvalidArgumentException naming the frames (tf2 stores it and fails lookups).
"""
from __future__ import annotations

from typing import Any, Union

from . import _pathcode
from .arguments import check_frame_id
from .errors import (ConnectivityException, ExtrapolationException, InvalidArgumentException,
                     LookupException, TransformException)
from .stamped import LATEST
from .static_cache import StaticCache
from .time_cache import TimeCache
from .transform import IDENTITY7, _compose

Cache = Union[TimeCache, StaticCache]

_PATH_CACHE_MAX = 4096


def _identity_ev(t: float) -> tuple:
    return IDENTITY7


def not_connected(target: str, source: str, target_root: str,
                  source_root: str) -> ConnectivityException:
    """tf2's connectivity error, naming the root each walk ended at."""
    return ConnectivityException(
        f"Could not find a connection between '{target}' and '{source}' because they are not "
        f"part of the same tree. Tf has two or more unconnected trees. ('{target}' is in the "
        f"tree rooted at '{target_root}', '{source}' in the tree rooted at '{source_root}'.)",
        target_frame=target, source_frame=source)


class FrameGraph:
    """Frames, the edge cache of each child frame, and the paths between frames.

    Not locked: the buffer holds its lock around every call. ``edges`` (child -> cache),
    ``frames`` (every id ever seen, in order) and ``paths`` are read by the buffer's
    lookups directly and changed only here.
    """

    def __init__(self) -> None:
        self.edges: dict[str, Cache] = {}
        self.frames: dict[str, None] = {}
        # (target, source) -> (source-side edges, target-side edges, dynamic ones, evaluator)
        self.paths: dict[tuple[str, str], tuple] = {}
        self.version = 0

    # ------------------------------------------------------------------ changes
    def attach(self, cache: Cache) -> Cache:
        """Make ``cache`` the edge of its child frame, replacing any edge it had.

        Raises InvalidArgumentException if the child is an ancestor of the new parent."""
        child, parent = cache.child, cache.parent
        edges = self.edges
        old = edges.get(child)
        if old is None or old.parent != parent:
            e = edges.get(parent)
            while e is not None and e.parent is not None:
                if e.parent == child:
                    raise InvalidArgumentException(
                        f"Refusing to make \"{parent}\" the parent of \"{child}\": \"{child}\" is "
                        f"already an ancestor of \"{parent}\", so the tree would contain a loop "
                        f"({child} -> ... -> {parent} -> {child})")
                e = edges.get(e.parent)
        edges[child] = cache
        self.frames.setdefault(parent, None)
        self.frames.setdefault(child, None)
        self._changed()
        return cache

    def clear(self) -> None:
        """Empty every dynamic edge (static ones stay); every frame stays known, but an
        emptied edge's parent is unknown until new data arrives, as in tf2."""
        emptied = False
        for e in self.edges.values():
            if not e.is_static and e.parent is not None:
                e.clear()
                emptied = True
        if emptied:
            self._changed()

    def _changed(self) -> None:
        self.paths.clear()
        self.version += 1

    # ------------------------------------------------------------------ paths
    def require(self, frame: Any, argument: str, fn: str) -> None:
        """tf2's validateFrameId: a valid id (InvalidArgumentException) of a known frame
        (LookupException), ``argument`` being e.g. "target_frame" of function ``fn``."""
        check_frame_id(frame, f"{fn} argument {argument}")
        if frame not in self.frames:
            raise LookupException(
                f"\"{frame}\" passed to {fn} argument {argument} does not exist. ",
                frame=frame, argument=argument)

    def path(self, target: str, source: str, fn: str) -> tuple:
        """(source-side edges up to the common ancestor, target-side edges likewise, the
        dynamic edges among them, the evaluator t -> 7-tuple of target <- source)."""
        try:
            p = self.paths.get((target, source))
        except TypeError:  # unhashable id: require() says what is wrong with it
            p = None
        if p is not None:
            return p
        self.require(target, "target_frame", fn)
        self.require(source, "source_frame", fn)
        edges = self.edges
        if target == source:
            e = edges.get(source)
            dyn = (e,) if e is not None and not e.is_static and e.parent is not None else ()
            p = ((), (), dyn, _identity_ev)
        else:
            up: dict[str, int] = {source: 0}
            chain_s: list[Cache] = []
            e = edges.get(source)
            while e is not None and e.parent is not None:
                chain_s.append(e)
                up[e.parent] = len(chain_s)
                e = edges.get(e.parent)
            chain_t: list[Cache] = []
            f = target
            while f not in up:
                e = edges.get(f)
                if e is None or e.parent is None:
                    raise not_connected(target, source, f,
                                        chain_s[-1].parent if chain_s else source)
                chain_t.append(e)
                f = e.parent
            chain_s = chain_s[:up[f]]
            make = _pathcode.factory(tuple(e.is_static for e in chain_s),
                                     tuple(e.is_static for e in chain_t))
            p = (tuple(chain_s), tuple(chain_t),
                 tuple(e for e in chain_s + chain_t if not e.is_static),
                 make(*chain_s, *chain_t, target, source))
        if len(self.paths) >= _PATH_CACHE_MAX:
            self.paths.clear()
        self.paths[(target, source)] = p
        return p

    def chain(self, target: str, source: str) -> list[str]:
        """Frames from source up to the common ancestor and down to target, ends included."""
        src, tgt, _, _ = self.path(target, source, "chain")
        if not src and not tgt:
            return [source]
        up = [e.child for e in src] + [src[-1].parent if src else tgt[-1].parent]
        return up + [e.child for e in tgt][::-1]

    # ------------------------------------------------------------------ lookups
    def own_latest(self, frame: str) -> float:
        """LATEST for a frame to itself: its own newest stamp (tf2's getLatestTimestamp of
        its cache), 0.0 if static, a root, emptied or unknown."""
        e = self.edges.get(frame)
        return e.latest() if e is not None else 0.0

    def latest_common_time(self, target: str, source: str) -> float:
        """What LATEST resolves to for target <- source; raises like a lookup."""
        dyn = self.path(target, source, "getLatestCommonTime")[2]
        if target == source:
            return self.own_latest(source)
        return min((e.stamps[-1] for e in dyn), default=0.0)

    def resolve(self, target: str, source: str, time: Any,
                fn: str = "lookupTransform") -> tuple[float, tuple]:
        """(stamp used, 7-tuple of target <- source) at ``time`` (a float or LATEST)."""
        if target == source and type(target) is str:
            return (self.own_latest(target) if time is LATEST else time), IDENTITY7
        try:
            p = self.paths.get((target, source))
        except TypeError:
            p = None
        if p is None:
            try:
                p = self.path(target, source, fn)
            except ConnectivityException as exc:
                if time is LATEST:
                    raise   # tf2's getLatestCommonTime: different trees are a connectivity error
                raise self.walk_error(target, source, time, exc) from None
        if time is LATEST:
            t = 0.0
            dyn = p[2]
            if dyn:
                t = dyn[0].stamps[-1]
                for e in dyn:
                    s = e.stamps[-1]
                    if s < t:
                        t = s
        else:
            t = time
        try:
            return t, p[3](t)
        except ExtrapolationException as exc:
            raise self.walk_error(target, source, t, exc) from None

    def resolve_full(self, target: str, target_time: Any, source: str, source_time: Any,
                     fixed: str) -> tuple[float, tuple]:
        """(target_time used, 7-tuple of T(target@target_time <- fixed) * T(fixed <-
        source@source_time)); all three ids are validated first, as tf2 does."""
        for frame, arg in ((target, "target_frame"), (source, "source_frame"),
                           (fixed, "fixed_frame")):
            self.require(frame, arg, "lookupTransform")
        _, a = self.resolve(fixed, source, source_time)
        t, b = self.resolve(target, fixed, target_time)
        return t, _compose(b, a)

    def walk_error(self, target: str, source: str, t: float,
                   fallback: TransformException) -> TransformException:
        """The error tf2's walkToTopParent reports for a lookup that failed at time t
        (see the module docstring); ``fallback`` if the walk finds nothing wrong."""
        edges = self.edges
        src_err = None
        f = source
        while f in edges and f != target:
            e = edges[f]
            src_err = e.check_at(t, target, source)
            if src_err is not None:
                break
            f = e.parent
        top = f
        g = target
        while g != top and g != source:
            e = edges.get(g)
            if e is None:
                break
            err = e.check_at(t, target, source)
            if err is not None:
                return err
            g = e.parent
        if g == top or g == source:
            return fallback
        if src_err is not None:
            return src_err
        return not_connected(target, source, g, top)


__all__ = ["FrameGraph", "not_connected"]
