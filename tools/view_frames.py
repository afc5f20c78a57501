"""Draw the frame tree, like tf2_tools view_frames, with each edge's statistics.

Every edge parent -> child is labelled with its broadcaster (authority), average
rate, most recent and oldest transform (and how old the newest is), and buffer
length. Sources:

  live (default)  listen to the bridge's transform stream (TOWERLINK_TRANSFORM) on a
                  UDP port it pushes to, for --duration wall seconds
  --tlog FILE     every TOWERLINK_TRANSFORM recorded in a tlog (a run's bridge.tlog),
                  or the /tf and /tf_static channels of a run's run.mcap
  --scenario FILE the scenario's static frames only (no MAVLink needed)

Output: -o frames.pdf | frames.png | frames.svg (default frames.pdf). With Graphviz
`dot` on PATH it lays the graph out (and frames.gv is kept beside, as tf2 does);
without it the tree is drawn by this tool (SVG written by hand, PNG/PDF with
matplotlib). The text form (tf2's allFramesAsYAML) is printed and written beside
the drawing as .yaml.

Examples:
  towerlink view-frames                                   # listen on udpin:127.0.0.1:14610 for 5 s (bridge --out udpout:127.0.0.1:14610)
  towerlink view-frames --tlog runs/latest/bridge.tlog -o frames.png
  towerlink view-frames --scenario common/scenarios/default.toml -o frames.svg
"""
from __future__ import annotations

import argparse
import html
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

DEFAULT_LISTEN = "udpin:127.0.0.1:14610"


# ----------------------------------------------------------------------------- sources


def buffer_from_messages(msgs, cache_time: float = 10.0):
    """A Buffer filled from decoded messages (TOWERLINK_TRANSFORM; others ignored)."""
    from common.frames import Buffer
    from bridge.listener import TransformListener
    listener = TransformListener(Buffer(cache_time=cache_time))
    for m in msgs:
        listener.feed(m)
    return listener.buffer, listener.newest_stamp


def buffer_from_tlog(path: str | os.PathLike, cache_time: float = 10.0):
    """(Buffer, newest stamp) from a tlog, or from a run.mcap (by its .mcap ending)."""
    if str(path).endswith(".mcap"):
        from tools.run_mcap import buffer_from_mcap
        buf, _stamps, latest = buffer_from_mcap(path, cache_time)
        return buf, latest
    from tools.run_data import read_tlog
    return buffer_from_messages(read_tlog(path, ("TOWERLINK_TRANSFORM",)), cache_time)


def buffer_from_scenario(path: str | None):
    from common.scenario import load_scenario
    return load_scenario(path).buffer(), 0.0


def buffer_from_live(url: str, duration: float, cache_time: float = 10.0):
    from common.mavlink.dialect import mavlink_connection
    from common.frames import Buffer
    from bridge.listener import TransformListener
    conn = mavlink_connection(url, source_system=255, source_component=191)
    listener = TransformListener(Buffer(cache_time=cache_time))
    end = time.monotonic() + duration
    try:
        while True:
            left = end - time.monotonic()
            if left <= 0:
                break
            m = conn.recv_match(type="TOWERLINK_TRANSFORM", blocking=True, timeout=min(left, 0.5))
            if m is not None:
                listener.feed(m)
    finally:
        conn.close()
    return listener.buffer, listener.newest_stamp


# ----------------------------------------------------------------------------- model


@dataclass(frozen=True)
class Edge:
    parent: str
    child: str
    label: tuple[str, ...]
    static: bool


def edge_label(s, now: float) -> tuple[str, ...]:
    """tf2 view_frames' edge text for one EdgeStats (static edges read like tf2's)."""
    if s.is_static:
        return (f"Broadcaster: {s.authority}", "Average rate: static",
                "Most recent transform: static", "Oldest transform: static",
                "Buffer length: static")
    age = max(0.0, now - s.most_recent) if now else 0.0
    return (f"Broadcaster: {s.authority}",
            f"Average rate: {s.rate_hz:.3f} Hz",
            f"Most recent transform: {s.most_recent:.3f} ({age:.3f} sec old)",
            f"Oldest transform: {s.oldest:.3f}",
            f"Buffer length: {s.buffer_length:.3f} sec")


def graph_of(buffer, now: float | None = None) -> tuple[list[str], list[Edge]]:
    """Frames (parents before children) and labelled edges of a Buffer."""
    stats = buffer.edge_stats()
    if now is None:
        now = max((s.most_recent for s in stats.values() if not s.is_static), default=0.0)
    edges = [Edge(s.parent, s.child, edge_label(s, now), s.is_static)
             for s in sorted(stats.values(), key=lambda s: (s.parent, s.child))]
    children = {e.child for e in edges}
    roots = sorted({e.parent for e in edges} - children)
    order: list[str] = []
    kids: dict[str, list[str]] = {}
    for e in edges:
        kids.setdefault(e.parent, []).append(e.child)

    def walk(f: str) -> None:
        order.append(f)
        for c in sorted(kids.get(f, [])):
            walk(c)
    for r in roots:
        walk(r)
    return order, edges


def layout(frames: list[str], edges: list[Edge]) -> dict[str, tuple[float, float]]:
    """Tidy tree layout: (x, depth) per frame; leaves at consecutive x, parents centred."""
    kids: dict[str, list[str]] = {}
    parent = {}
    for e in edges:
        kids.setdefault(e.parent, []).append(e.child)
        parent[e.child] = e.parent
    pos: dict[str, tuple[float, float]] = {}
    nxt = [0.0]

    def place(f: str, depth: int) -> float:
        cs = sorted(kids.get(f, []))
        if not cs:
            x = nxt[0]
            nxt[0] += 1.0
        else:
            xs = [place(c, depth + 1) for c in cs]
            x = (xs[0] + xs[-1]) / 2.0
        pos[f] = (x, float(depth))
        return x
    for f in frames:
        if f not in parent and f not in pos:
            place(f, 0)
    return pos


# ----------------------------------------------------------------------------- renderers


def to_dot(frames: list[str], edges: list[Edge], title: str = "view_frames") -> str:
    """Graphviz source, shaped like tf2 view_frames' frames.gv."""
    out = ["digraph G {", f'  label="{_dot_esc(title)}";', "  labelloc=t;",
           '  node [shape=ellipse, fontname="Helvetica"];', '  edge [fontname="Helvetica", fontsize=9];']
    for f in frames:
        out.append(f'  "{_dot_esc(f)}";')
    for e in edges:
        lab = "\\n".join(_dot_esc(s) for s in e.label) + "\\n"
        style = ", style=dashed" if e.static else ""
        out.append(f'  "{_dot_esc(e.parent)}" -> "{_dot_esc(e.child)}" [label="{lab}"{style}];')
    out.append("}")
    return "\n".join(out) + "\n"


def _dot_esc(s: str) -> str:
    return s.replace("\\", "\\\\").replace('"', '\\"')


# geometry of the own drawing (SVG pixels)
COL_W, ROW_H, NODE_W, NODE_H, MARGIN, TITLE_H = 300.0, 190.0, 120.0, 40.0, 40.0, 40.0


def _coords(pos):
    xs = [p[0] for p in pos.values()] or [0.0]
    ys = [p[1] for p in pos.values()] or [0.0]
    w = (max(xs) - min(xs)) * COL_W + COL_W + 2 * MARGIN
    h = (max(ys) - min(ys)) * ROW_H + NODE_H + 2 * MARGIN + TITLE_H
    return {f: (MARGIN + COL_W / 2 + (x - min(xs)) * COL_W, MARGIN + TITLE_H + NODE_H / 2 + y * ROW_H)
            for f, (x, y) in pos.items()}, w, h


def _label_anchor(x_child: float, y_child: float, lines: int) -> tuple[float, float]:
    """Top-centre of an edge's label: just above its child, so siblings never overlap."""
    return x_child, y_child - NODE_H / 2 - 14 - 12 * lines


def _label_span(x_child: float, y_child: float, lines: int) -> tuple[float, float]:
    """(top, bottom) y of an edge's label box. Edges run parent -> label top and label
    bottom -> child, as Graphviz routes labelled edges, so no line crosses another label."""
    _, my = _label_anchor(x_child, y_child, lines)
    return my - 11, my - 5 + 12 * lines


def to_svg(frames: list[str], edges: list[Edge], title: str = "view_frames") -> str:
    """The tree as a self-contained SVG (no Graphviz needed)."""
    pos = layout(frames, edges)
    xy, w, h = _coords(pos)
    o = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h:.0f}" '
         f'viewBox="0 0 {w:.0f} {h:.0f}" font-family="Helvetica, Arial, sans-serif">',
         '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="8" '
         'markerHeight="8" orient="auto-start-reverse"><path d="M 0 0 L 10 5 L 0 10 z"/></marker></defs>',
         '<rect width="100%" height="100%" fill="white"/>',
         f'<text x="{w / 2:.1f}" y="{MARGIN - 10 + 16:.1f}" text-anchor="middle" font-size="16">'
         f'{html.escape(title)}</text>']
    for e in edges:
        (x0, y0), (x1, y1) = xy[e.parent], xy[e.child]
        dash = ' stroke-dasharray="6,4"' if e.static else ""
        top, bottom = _label_span(x1, y1, len(e.label))
        o.append(f'<line x1="{x0:.1f}" y1="{y0 + NODE_H / 2:.1f}" x2="{x1:.1f}" y2="{top:.1f}" '
                 f'stroke="black"{dash}/>')
        o.append(f'<line x1="{x1:.1f}" y1="{bottom:.1f}" x2="{x1:.1f}" y2="{y1 - NODE_H / 2:.1f}" '
                 f'stroke="black"{dash} marker-end="url(#arrow)"/>')
        mx, my = _label_anchor(x1, y1, len(e.label))
        bw = 6.0 * max(len(s) for s in e.label) + 10
        o.append(f'<rect x="{mx - bw / 2:.1f}" y="{my - 11:.1f}" width="{bw:.1f}" '
                 f'height="{12 * len(e.label) + 6:.1f}" fill="white" fill-opacity="0.9" stroke="#bbb"/>')
        for k, line in enumerate(e.label):
            o.append(f'<text x="{mx:.1f}" y="{my + 12 * k:.1f}" font-size="10" '
                     f'text-anchor="middle">{html.escape(line)}</text>')
    for f in frames:
        x, y = xy[f]
        o.append(f'<ellipse cx="{x:.1f}" cy="{y:.1f}" rx="{NODE_W / 2:.1f}" ry="{NODE_H / 2:.1f}" '
                 'fill="white" stroke="black"/>')
        o.append(f'<text x="{x:.1f}" y="{y + 5:.1f}" text-anchor="middle" font-size="14">{html.escape(f)}</text>')
    o.append("</svg>")
    return "\n".join(o) + "\n"


def render_matplotlib(frames: list[str], edges: list[Edge], path: str | os.PathLike,
                      title: str = "view_frames") -> None:
    """The same drawing as to_svg, as PNG or PDF through matplotlib."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse

    pos = layout(frames, edges)
    xy, w, h = _coords(pos)
    dpi = 100
    fig = plt.figure(figsize=(max(w, 400) / dpi, max(h, 300) / dpi), dpi=dpi)
    ax = fig.add_axes([0, 0, 1, 1])
    ax.set_xlim(0, max(w, 400))
    ax.set_ylim(max(h, 300), 0)
    ax.axis("off")
    ax.text(max(w, 400) / 2, MARGIN, title, ha="center", va="center", fontsize=13)
    for e in edges:
        (x0, y0), (x1, y1) = xy[e.parent], xy[e.child]
        top, bottom = _label_span(x1, y1, len(e.label))
        ls = "--" if e.static else "-"
        ax.plot([x0, x1], [y0 + NODE_H / 2, top], color="black", linestyle=ls, lw=1.0)
        ax.annotate("", xy=(x1, y1 - NODE_H / 2), xytext=(x1, bottom),
                    arrowprops=dict(arrowstyle="-|>", color="black", linestyle=ls, lw=1.0))
        mx, my = _label_anchor(x1, y1, len(e.label))
        ax.text(mx, my - 9 + 6 * len(e.label), "\n".join(e.label), fontsize=7, va="center",
                ha="center", family="sans-serif", linespacing=1.3,
                bbox=dict(boxstyle="round,pad=0.3", facecolor="white", edgecolor="#bbbbbb", alpha=0.95))
    for f in frames:
        x, y = xy[f]
        ax.add_patch(Ellipse((x, y), NODE_W, NODE_H, facecolor="white", edgecolor="black"))
        ax.text(x, y, f, ha="center", va="center", fontsize=10)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def write_drawing(buffer, out: str | os.PathLike, *, now: float | None = None,
                  title: str = "view_frames", use_dot: bool | None = None) -> list[Path]:
    """Write the tree to `out` (.pdf/.png/.svg) and the YAML beside it; returns the files."""
    out = Path(out)
    fmt = out.suffix.lower().lstrip(".") or "pdf"
    if fmt not in ("pdf", "png", "svg"):
        raise ValueError(f"output must end in .pdf, .png or .svg, not {out.name!r}")
    frames, edges = graph_of(buffer, now)
    written = []
    dot = shutil.which("dot") if use_dot is None or use_dot else None
    if dot:
        gv = out.with_suffix(".gv")
        gv.write_text(to_dot(frames, edges, title))
        subprocess.run([dot, f"-T{fmt}", str(gv), "-o", str(out)], check=True)
        written += [out, gv]
    elif fmt == "svg":
        out.write_text(to_svg(frames, edges, title))
        written.append(out)
    else:
        render_matplotlib(frames, edges, out, title)
        written.append(out)
    yml = out.with_suffix(".yaml")
    yml.write_text(buffer.all_frames_as_yaml(now if now else None))
    written.append(yml)
    return written


# ----------------------------------------------------------------------------- CLI


def add_arguments(parser: argparse.ArgumentParser) -> None:
    src = parser.add_mutually_exclusive_group()
    src.add_argument("--listen", default=DEFAULT_LISTEN,
                     help=f"listen for the bridge's transform stream here (default {DEFAULT_LISTEN})")
    src.add_argument("--tlog", default=None,
                     help="read TOWERLINK_TRANSFORMs from a tlog (or /tf from a run.mcap) instead")
    src.add_argument("--scenario", default=None, nargs="?", const="",
                     help="draw a scenario's static frames (no argument: the built-in default)")
    parser.add_argument("--duration", type=float, default=5.0,
                        help="wall seconds to listen (live; default 5, as tf2 view_frames)")
    parser.add_argument("--cache-time", type=float, default=10.0,
                        help="buffer window, s (the statistics cover at most this much)")
    parser.add_argument("-o", "--output", default="frames.pdf", help="frames.pdf | .png | .svg")
    parser.add_argument("--no-dot", action="store_true", help="do not use Graphviz even if installed")


def run(args: argparse.Namespace) -> int:
    if args.tlog:
        from tools.recording_file import require_recording
        try:
            require_recording(args.tlog)
        except OSError as exc:
            print(f"view-frames: {exc}", file=sys.stderr)
            return 2
        buf, now = buffer_from_tlog(args.tlog, args.cache_time)
        title = f"view_frames: {args.tlog}"
    elif args.scenario is not None:
        buf, now = buffer_from_scenario(args.scenario or None)
        title = f"view_frames: scenario {args.scenario or 'default'}"
    else:
        print(f"Listening to the transform stream on {args.listen} for {args.duration:g} s ...",
              flush=True)
        buf, now = buffer_from_live(args.listen, args.duration, args.cache_time)
        title = f"view_frames: {args.listen}, {time.strftime('%Y-%m-%d %H:%M:%S')}"
    if not buf.edge_stats():
        print("no transforms received" + ("" if args.tlog or args.scenario is not None else
              " (is the bridge pushing its transform stream to this port?)"), file=sys.stderr)
        return 1
    print(buf.all_frames_as_yaml(now if now else None), end="")
    try:
        files = write_drawing(buf, args.output, now=now, title=title,
                              use_dot=False if args.no_dot else None)
    except (ValueError, OSError, subprocess.CalledProcessError) as exc:
        print(f"view-frames: {exc}", file=sys.stderr)
        return 2
    print("wrote " + ", ".join(str(f) for f in files))
    return 0
