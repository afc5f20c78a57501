"""What the buffer reports about its edges: :class:`EdgeStats` and tf2's two frame listings.

tf2's allFramesAsString and allFramesAsYAML read every cache; here they read the
:class:`EdgeStats` each edge's cache reports (:mod:`.time_cache`, :mod:`.static_cache`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

#: What tf2 prints for a frame whose parent is unknown (an edge emptied by clear()).
NO_PARENT = "NO_PARENT"


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


def frames_as_string(edges: Iterable) -> str:
    """tf2's allFramesAsString: one "Frame X exists with parent Y." line per child frame.

    ``edges``: the buffer's edge caches (``child`` and ``parent``, None when unknown)."""
    return "".join(f"Frame {e.child} exists with parent "
                   f"{NO_PARENT if e.parent is None else e.parent}.\n" for e in edges)


def frames_as_yaml(stats: list[EdgeStats], current_time: float | None = None) -> str:
    """tf2's allFramesAsYAML of these edges: per child frame its parent, broadcaster,
    rate, most_recent_transform, oldest_transform, (transform_delay if current_time is
    given and > 0) and buffer_length, 3 decimals. Static edges read like tf2's: rate
    10000.000 and stamps 0.000. No edges give "[]"."""
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


__all__ = ["EdgeStats", "NO_PARENT", "frames_as_string", "frames_as_yaml"]
