"""The frame tree of a `towerlink fly` run (frames.pdf, frames.png, frames.yaml), from bridge.tlog's transforms.

:func:`draw_frames` draws it from the finished bridge.tlog; :func:`frames_when_over` does that in a
sub-helper of the drawings' child (tools.fly_drawings), beside the child drawing tracks.png. A
drawing that fails is left out and never hides the summary.
"""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from tools.fly_child import Priority


def draw_frames(run_dir: Path, bridge: Iterable | None = None) -> None:
    """frames.pdf, frames.png and frames.yaml from bridge.tlog's transforms (`bridge`: its messages,
    the transforms among them decoded, already read); left out if it fails or the bridge
    recorded no transform."""
    try:
        from tools.view_frames import buffer_from_messages, buffer_from_tlog, write_drawing
        if bridge is None:
            buf, now = buffer_from_tlog(run_dir / "bridge.tlog")
        else:
            buf, now = buffer_from_messages(m for m in bridge if m.get_type() == "TOWERLINK_TRANSFORM")
        if buf.edge_stats():
            title = f"view_frames: {run_dir.name}"
            write_drawing(buf, run_dir / "frames.pdf", now=now, title=title)
            write_drawing(buf, run_dir / "frames.png", now=now, title=title)
    except Exception:  # noqa: BLE001
        pass


def prepare_pdf() -> None:
    """Write a PDF with text to memory: a process's first one imports matplotlib's font subsetting
    (fontTools, some 0.08 s of CPU), paid here while the run flies rather than by frames.pdf."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(1, 1))
    fig.text(0.5, 0.5, "view_frames")
    fig.savefig(io.BytesIO(), format="pdf")
    plt.close(fig)


def frames_when_over(run_dir: Path, priority: Priority | None, conn) -> None:
    """A sub-helper's main: once the parent says the flight is over (anything sent), draw; nothing
    when the pipe closes first (the run was given up)."""
    try:
        conn.recv()
    except (EOFError, OSError):
        return
    if priority is not None:
        priority.restore()      # the drawing is on the run's critical path now
    draw_frames(Path(run_dir))
