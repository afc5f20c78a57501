"""The one value of a static edge parent -> child (tf2's StaticCache, static_cache.cpp).

A static edge answers every time and never expires; a new value replaces the old one.
clear() leaves it alone (tf2's StaticCache::clearList is a no-op too).
"""
from __future__ import annotations

from .edge_stats import EdgeStats
from .transform import IDENTITY7


class StaticCache:
    """The static edge ``parent`` -> ``child``: ``value`` (7-tuple) and the ``stamp`` it came with."""

    __slots__ = ("child", "parent", "value", "stamp", "authority", "inserts")
    is_static = True
    rejected_old = 0     # a static value is never too old

    def __init__(self, child: str, parent: str, authority: str) -> None:
        self.child = child
        self.parent = parent
        self.value: tuple = IDENTITY7
        self.stamp = 0.0
        self.authority = authority
        self.inserts = 0

    def insert(self, stamp: float, v: tuple, authority: str) -> bool:
        """Replace the value; always True."""
        self.value = v
        self.stamp = stamp
        self.authority = authority
        self.inserts += 1
        return True

    def clear(self) -> None:
        """Nothing to drop: static values survive clear(), as in tf2."""

    def latest(self) -> float:
        """0.0: a static edge has no newest time (tf2's Time(0))."""
        return 0.0

    def check_at(self, t: float, target: str, source: str) -> None:
        """None: a static edge has data at every time."""
        return None

    def stats(self) -> EdgeStats:
        """This edge's :class:`EdgeStats` (one sample; most_recent = oldest = its stamp)."""
        return EdgeStats(self.child, self.parent, self.authority, True, 0.0, 0.0,
                         self.stamp, self.stamp, 1, self.inserts, 0)


__all__ = ["StaticCache"]
