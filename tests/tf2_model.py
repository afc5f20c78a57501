"""tf2's BufferCore rules, transliterated from ros2/geometry2 for tests to hold Buffer against.

Written from tf2/src/buffer_core.cpp (validateFrameId, lookupTransformImpl, canTransform,
walkToTopParent, getLatestCommonTime, clear) and tf2/src/cache.cpp / static_cache.cpp
(findClosest, getLatestTimeAndParent, clearList), keeping their structure and quirks: the
parent is stored with every sample, frame ids go into a table on insert and never leave,
the walks stop at a cache that has no data. It implements Buffer's documented deviations
on insert only (one parent per cache: a new parent starts a new cache; the last sample per
stamp; pruning before 0.37; loops refused) so that both hold the same samples, and it
never sees a stamp of 0 (tf2's "latest"). Errors come back as values, not exceptions:
("lookup" | "invalid" | "connectivity", None) or ("past" | "future" | "nodata" | "empty",
the child frame whose cache failed), "nodata" being tf2's NoDataForExtrapolation of a cache
with one sample and "empty" that of a cache emptied by clear().
"""
from __future__ import annotations

from common.frames import LATEST
from common.frames.transform import IDENTITY7, _compose, _interpolate, _inverse


class ModelError(Exception):
    """A tf2 error: ``kind`` and, for extrapolation, the ``frame`` whose cache failed."""

    def __init__(self, kind: str, frame: str | None = None) -> None:
        super().__init__(kind, frame)
        self.kind, self.frame = kind, frame


class Tf2Model:
    """Frame table + one cache per child frame: ("static", parent, value) or a list of
    (stamp, parent, value), newest last."""

    def __init__(self, cache_time: float) -> None:
        self.cache_time = cache_time
        self.known: set[str] = set()
        self.caches: dict[str, object] = {}

    # ---------------------------------------------------------------- caches
    def _parent(self, frame: str) -> str | None:
        """The parent of a frame's newest data (getLatestTimeAndParent), None without data."""
        c = self.caches.get(frame)
        if c is None or not c:
            return None
        return c[1] if isinstance(c, tuple) else c[-1][1]

    def insert(self, parent: str, child: str, stamp: float, value: tuple, static: bool) -> str:
        """"ok", "old" (TF_OLD_DATA) or "loop" (refused: Buffer's deviation)."""
        if self._parent(child) != parent:
            f = parent
            while (p := self._parent(f)) is not None:
                if p == child:
                    return "loop"
                f = p
        self.known.update((parent, child))
        c = self.caches.get(child)
        if static:
            self.caches[child] = ("static", parent, value)
            return "ok"
        if not isinstance(c, list) or (c and c[-1][1] != parent):
            c = self.caches[child] = []
        if c and stamp < c[-1][0] - self.cache_time:
            return "old"
        c[:] = sorted([s for s in c if s[0] != stamp] + [(stamp, parent, value)], key=lambda s: s[0])
        newest = c[-1][0]
        c[:] = [s for s in c if s[0] >= newest - self.cache_time]
        return "ok"

    def clear(self) -> None:
        for c in self.caches.values():
            if isinstance(c, list):
                c.clear()

    def _gather(self, frame: str, t: float) -> tuple[str, tuple]:
        """(parent, value) of a frame's cache at time t (findClosest + interpolate)."""
        c = self.caches[frame]
        if isinstance(c, tuple):
            return c[1], c[2]
        if not c:
            raise ModelError("empty", frame)     # cleared: no data, and so no parent
        if len(c) == 1:
            if c[0][0] == t:
                return c[0][1], c[0][2]
            raise ModelError("nodata", frame)
        if t > c[-1][0]:
            raise ModelError("future", frame)
        if t < c[0][0]:
            raise ModelError("past", frame)
        for (s0, p0, v0), (s1, _, v1) in zip(c, c[1:]):
            if s0 <= t <= s1:
                return p0, (v0 if t == s0 else v1 if t == s1 else
                            _interpolate(v0, v1, (t - s0) / (s1 - s0)))
        raise AssertionError("unreachable")

    # ---------------------------------------------------------------- lookups
    def _validate(self, frame: str) -> None:
        if frame == "" or frame.startswith("/"):
            raise ModelError("invalid")
        if frame not in self.known:
            raise ModelError("lookup")

    def lookup(self, target: str, source: str, time) -> tuple[float, tuple]:
        """lookupTransformImpl: (stamp, 7-tuple of target <- source) or ModelError."""
        if target == source:
            if time is LATEST:
                c = self.caches.get(target)
                return (c[-1][0] if isinstance(c, list) and c else 0.0), IDENTITY7
            return time, IDENTITY7
        self._validate(target)
        self._validate(source)
        if time is LATEST:
            time = self._latest_common_time(target, source)
        return time, self._walk(target, source, time)

    def can_transform(self, target: str, source: str, time) -> bool:
        try:
            self.lookup(target, source, time)
        except ModelError:
            return False
        return True

    def _walk(self, target: str, source: str, t: float) -> tuple:
        """walkToTopParent with TransformAccum."""
        src_acc, extrapolation = IDENTITY7, None
        frame = top = source
        while True:
            if frame not in self.caches:         # a root has no cache
                top = frame
                break
            try:
                parent, v = self._gather(frame, t)
            except ModelError as e:
                top, extrapolation = frame, e
                break
            if frame == target:                  # TargetParentOfSource
                return src_acc
            src_acc = _compose(v, src_acc)
            top, frame = frame, parent
        tgt_acc = IDENTITY7
        frame = target
        while frame != top:
            if frame not in self.caches:
                break
            parent, v = self._gather(frame, t)   # an error here is reported at once
            if frame == source:                  # SourceParentOfTarget
                return _inverse(tgt_acc)
            tgt_acc = _compose(v, tgt_acc)
            frame = parent
        if frame != top:
            if extrapolation is not None:
                raise extrapolation
            raise ModelError("connectivity")
        return _compose(_inverse(tgt_acc), src_acc)

    def _up(self, frame: str):
        """(newest stamp, parent) of each cache from ``frame`` up, until a root or a cache
        without data (getLatestTimeAndParent; a static cache's stamp is 0)."""
        while frame in self.caches:
            c = self.caches[frame]
            if isinstance(c, tuple):
                t, parent = 0.0, c[1]
            elif c:
                t, parent = c[-1][0], c[-1][1]
            else:
                return
            yield t, parent
            frame = parent

    def _latest_common_time(self, target: str, source: str) -> float:
        """getLatestCommonTime (zero stamps, i.e. statics, do not count)."""
        inf = float("inf")
        lct: list[tuple[float, str]] = []
        common = inf
        for t, parent in self._up(source):
            common = min(common, t or inf)
            lct.append((t, parent))
            if parent == target:
                return 0.0 if common == inf else common
        common, common_parent = inf, None
        for t, parent in self._up(target):
            common = min(common, t or inf)
            if parent in [p for _, p in lct]:
                common_parent = parent
                break
            if parent == source:
                return 0.0 if common == inf else common
        if common_parent is None:
            raise ModelError("connectivity")
        for t, p in lct:
            common = min(common, t or inf)
            if p == common_parent:
                break
        return 0.0 if common == inf else common
