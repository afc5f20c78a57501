"""Straight-line evaluators for frame paths, generated once per path *shape*.

A lookup walks edges from the source up to the common ancestor and from the
target up to it, samples each edge at time t (exact sample, or linear
translation + shortest-path SLERP between two samples), composes each side and
finally computes inv(target side) * (source side). Written as a generic loop over
helper functions, a third of the time goes to calls and packing tuples. This
module writes that loop out for a given shape -- which edges are static and which
dynamic, on each side -- with all the float math inline, compiles it once per
shape, and binds it to a path's edge objects with a closure.

This is the only evaluator lookups use. tests/frames_reference.py keeps the same
computation written as the plain loop over the helper functions; the buffer tests
check the generated code against it (bit for bit) and chains against independent
matrix products.
SLERP constants per segment come from ``E.segs`` (computed on insert, see
``time_cache.segment``). Edges are read at call time (``E.value`` of a StaticCache,
``E.stamps``, ``E.values``, ``E.segs`` of a TimeCache), so new samples and updated
static values are seen without regenerating; a change of tree structure drops the
path cache (graph.FrameGraph) and so rebinds. Outside its samples an edge raises
``E.error_at(t, TGT, SRC)``.
"""
from __future__ import annotations

import math
from bisect import bisect_left
from typing import Callable

_cache: dict[tuple[tuple[bool, ...], tuple[bool, ...]], Callable] = {}


def _sample(lines: list[str], k: int, static: bool, o: str) -> None:
    """Code that sets o0..o6 to edge E{k} at time t."""
    outs = ", ".join(f"{o}{j}" for j in range(7))
    if static:
        lines.append(f"    {outs} = E{k}.value")
        return
    lines += [
        f"    st = E{k}.stamps",
        "    i = _bl(st, t)",
        "    n = len(st)",
        "    if i < n and st[i] == t:",
        f"        {outs} = E{k}.values[i]",
        "    elif 0 < i < n:",
        f"        vs = E{k}.values",
        "        s0 = st[i - 1]",
        "        s = (t - s0) / (st[i] - s0)",
        "        x0, y0, z0, p0, p1, p2, p3 = vs[i - 1]",
        "        x1, y1, z1, q0, q1, q2, q3 = vs[i]",
        f"        th, sp, sq = E{k}.segs[i]",
        "        if th:",
        "            k0 = _sin((1.0 - s) * th) * sp",
        "            k1 = _sin(s * th) * sq",
        f"            {o}3 = k0 * p0 + k1 * q0",
        f"            {o}4 = k0 * p1 + k1 * q1",
        f"            {o}5 = k0 * p2 + k1 * q2",
        f"            {o}6 = k0 * p3 + k1 * q3",
        "        else:",
        "            w0 = p0 + (sq * q0 - p0) * s",
        "            w1 = p1 + (sq * q1 - p1) * s",
        "            w2 = p2 + (sq * q2 - p2) * s",
        "            w3 = p3 + (sq * q3 - p3) * s",
        "            m = 1.0 / _sqrt(w0 * w0 + w1 * w1 + w2 * w2 + w3 * w3)",
        f"            {o}3 = w0 * m",
        f"            {o}4 = w1 * m",
        f"            {o}5 = w2 * m",
        f"            {o}6 = w3 * m",
        f"        {o}0 = x0 + (x1 - x0) * s",
        f"        {o}1 = y0 + (y1 - y0) * s",
        f"        {o}2 = z0 + (z1 - z0) * s",
        "    else:",
        f"        raise E{k}.error_at(t, TGT, SRC)",
    ]


def _compose(lines: list[str], a: str, b: str, c: str) -> None:
    """c = a * b (b first), same formulas as transform._compose."""
    lines += [
        f"    tx = 2.0 * ({a}4 * {b}2 - {a}5 * {b}1)",
        f"    ty = 2.0 * ({a}5 * {b}0 - {a}3 * {b}2)",
        f"    tz = 2.0 * ({a}3 * {b}1 - {a}4 * {b}0)",
        f"    {c}0 = {a}0 + {b}0 + {a}6 * tx + ({a}4 * tz - {a}5 * ty)",
        f"    {c}1 = {a}1 + {b}1 + {a}6 * ty + ({a}5 * tx - {a}3 * tz)",
        f"    {c}2 = {a}2 + {b}2 + {a}6 * tz + ({a}3 * ty - {a}4 * tx)",
        f"    {c}3 = {a}6 * {b}3 + {a}3 * {b}6 + {a}4 * {b}5 - {a}5 * {b}4",
        f"    {c}4 = {a}6 * {b}4 - {a}3 * {b}5 + {a}4 * {b}6 + {a}5 * {b}3",
        f"    {c}5 = {a}6 * {b}5 + {a}3 * {b}4 - {a}4 * {b}3 + {a}5 * {b}6",
        f"    {c}6 = {a}6 * {b}6 - {a}3 * {b}3 - {a}4 * {b}4 - {a}5 * {b}5",
    ]


def _inv_compose_return(lines: list[str], a: str, b: str) -> None:
    """return a.inverse() * b, same formulas as transform._inv_compose."""
    lines += [
        f"    vx = {b}0 - {a}0",
        f"    vy = {b}1 - {a}1",
        f"    vz = {b}2 - {a}2",
        f"    tx = 2.0 * (-{a}4 * vz + {a}5 * vy)",
        f"    ty = 2.0 * (-{a}5 * vx + {a}3 * vz)",
        f"    tz = 2.0 * (-{a}3 * vy + {a}4 * vx)",
        f"    return (vx + {a}6 * tx + (-{a}4 * tz + {a}5 * ty),",
        f"            vy + {a}6 * ty + (-{a}5 * tx + {a}3 * tz),",
        f"            vz + {a}6 * tz + (-{a}3 * ty + {a}4 * tx),",
        f"            {a}6 * {b}3 - {a}3 * {b}6 - {a}4 * {b}5 + {a}5 * {b}4,",
        f"            {a}6 * {b}4 + {a}3 * {b}5 - {a}4 * {b}6 - {a}5 * {b}3,",
        f"            {a}6 * {b}5 - {a}3 * {b}4 + {a}4 * {b}3 - {a}5 * {b}6,",
        f"            {a}6 * {b}6 + {a}3 * {b}3 + {a}4 * {b}4 + {a}5 * {b}5)",
    ]


def _side(lines: list[str], flags: tuple[bool, ...], first: int, acc: str) -> str:
    """Sample and compose one side's edges E{first}.. into accumulator names; returns
    the prefix holding the result."""
    cur = None
    for j, static in enumerate(flags):
        e = f"e{first + j}_"
        _sample(lines, first + j, static, e)
        if cur is None:
            cur = e
        else:
            nxt = f"{acc}{j}_"
            _compose(lines, e, cur, nxt)
            cur = nxt
    return cur  # type: ignore[return-value]


def source(src: tuple[bool, ...], tgt: tuple[bool, ...]) -> str:
    """Python source of a factory ``make(E0.., TGT, SRC) -> ev(t) -> 7-tuple``.

    ``src`` / ``tgt``: is-static flags of the source-side and target-side edges,
    each listed from the lookup's frame up to the common ancestor. At least one
    side is non-empty.
    """
    n = len(src) + len(tgt)
    params = ", ".join([f"E{k}" for k in range(n)] + ["TGT", "SRC"])
    lines = [f"def make({params}):", "  def ev(t):"]
    body: list[str] = []
    s = _side(body, src, 0, "s") if src else None
    g = _side(body, tgt, len(src), "g") if tgt else None
    if g is None:
        body.append("    return (" + ", ".join(f"{s}{j}" for j in range(7)) + ")")
    elif s is None:
        # inverse of the target side: inv(g) * identity
        body += [f"    i{j} = {v}" for j, v in enumerate(("0.0",) * 6 + ("1.0",))]
        _inv_compose_return(body, g, "i")
    else:
        _inv_compose_return(body, g, s)
    lines += ["  " + ln for ln in body]
    lines.append("  return ev")
    return "\n".join(lines) + "\n"


def factory(src: tuple[bool, ...], tgt: tuple[bool, ...]) -> Callable:
    """The compiled ``make`` for this shape (cached per shape)."""
    key = (src, tgt)
    f = _cache.get(key)
    if f is None:
        ns = {"_bl": bisect_left, "_sin": math.sin, "_sqrt": math.sqrt}
        exec(compile(source(src, tgt), f"<frames path {key}>", "exec"), ns)
        f = ns["make"]
        _cache[key] = f
    return f
