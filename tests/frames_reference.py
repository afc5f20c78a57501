"""A reference evaluator for Buffer lookups, for tests to compare the production path against.

Production evaluates a frame path with the straight-line code common/frames/_pathcode.py
generates per path shape. This is the same computation written as the plain loop over the
helper functions in common/frames/transform.py: sample each edge (exact stamp, or linear
translation + shortest-path SLERP between the two samples around t), compose each side up to
the common ancestor, then inv(target side) * (source side). It reads the buffer's stored edges
(through the buffer's FrameGraph.path, which also raises Lookup/Connectivity errors exactly as
a lookup does), so a test inserts once and asks both.
"""
from __future__ import annotations

from bisect import bisect_left
from typing import Any

from common.frames import LATEST, Buffer, Transform, TransformStamped
from common.frames.stamped import check_time
from common.frames.transform import IDENTITY7, _compose, _interpolate, _inv_compose, _inverse


def sample_edge(e, t: float, target: str, source: str) -> tuple:
    """One edge's 7-tuple at time t; raises the buffer's extrapolation error outside its data."""
    if e.is_static:
        return e.value
    stamps = e.stamps
    i = bisect_left(stamps, t)
    if i < len(stamps):
        s1 = stamps[i]
        if s1 == t:
            return e.values[i]
        if i:
            s0 = stamps[i - 1]
            return _interpolate(e.values[i - 1], e.values[i], (t - s0) / (s1 - s0))
    raise e.error_at(t, target, source)


def evaluate(src: tuple, tgt: tuple, t: float, target: str, source: str) -> tuple:
    """inv(compose(target side)) * compose(source side) at time t, edge by edge."""
    acc_s = None
    for e in src:
        v = sample_edge(e, t, target, source)
        acc_s = v if acc_s is None else _compose(v, acc_s)
    acc_t = None
    for e in tgt:
        v = sample_edge(e, t, target, source)
        acc_t = v if acc_t is None else _compose(v, acc_t)
    if acc_t is None:
        return IDENTITY7 if acc_s is None else acc_s
    if acc_s is None:
        return _inverse(acc_t)
    return _inv_compose(acc_t, acc_s)


def reference_lookup(buf: Buffer, target: str, source: str, time: Any = LATEST) -> TransformStamped:
    """What buf.lookup_transform(target, source, time) must return, computed the slow way."""
    if time is not LATEST:
        time = check_time(time)
    with buf._lock:
        src, tgt, dyn, _ = buf._graph.path(target, source, "lookupTransform")
        if time is LATEST:
            t = min((e.stamps[-1] for e in dyn), default=0.0)
        else:
            t = time
        v = evaluate(src, tgt, t, target, source)
    return TransformStamped(target, source, t, Transform._of(v))
