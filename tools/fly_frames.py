"""The frame tree of a `towerlink fly` run (frames.pdf, frames.png, frames.yaml), from bridge.tlog's transforms.

:func:`draw_frames` reads the finished bridge.tlog. :class:`LiveFrames` reads it while it grows
(tools.tlog_tail), feeding the same messages in the same order into the same listener, so once
the flight is over only the last slice and the drawing are left; :func:`live_frames` does that
in a sub-helper of the drawings' child (tools.fly_drawings), beside the one that draws
tracks.png. A drawing that fails is left out and never hides the summary.
"""
from __future__ import annotations

from pathlib import Path

from tools.fly_child import POLL_S, Priority

#: s of transforms the drawing's buffer keeps (tools.view_frames.buffer_from_tlog's default)
CACHE_S = 10.0


def draw_frames(run_dir: Path) -> None:
    """frames.pdf, frames.png and frames.yaml from the finished bridge.tlog; left out if it fails
    or the bridge recorded no transform."""
    try:
        from tools.view_frames import buffer_from_tlog
        buf, now = buffer_from_tlog(run_dir / "bridge.tlog", CACHE_S)
        write_frames(run_dir, buf, now)
    except Exception:  # noqa: BLE001
        pass


def write_frames(run_dir: Path, buf, now: float) -> None:
    """The drawings of the tree in `buf` (a common.frames.Buffer; `now`: its newest stamp, s),
    titled by the run folder's name; nothing when it holds no transform."""
    from tools.view_frames import write_drawing
    if buf.edge_stats():
        title = f"view_frames: {run_dir.name}"
        write_drawing(buf, run_dir / "frames.pdf", now=now, title=title)
        write_drawing(buf, run_dir / "frames.png", now=now, title=title)


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


class LiveFrames:
    """The tree of run_dir/bridge.tlog, read as it grows (:meth:`poll`), drawn by :meth:`finish`."""

    def __init__(self, run_dir: Path) -> None:
        from bridge.listener import TransformListener
        from common.frames import Buffer
        from tools.tlog_tail import TlogTail
        self.dir = Path(run_dir)
        self.tail = TlogTail(self.dir / "bridge.tlog", ("TOWERLINK_TRANSFORM",))
        self.listener = TransformListener(Buffer(cache_time=CACHE_S))
        self.broken = False         # not whole stamped frames: the finished file is read instead

    def poll(self) -> None:
        """Feed what bridge.tlog gained."""
        from tools.tlog_tail import NotATlog
        if self.broken:
            return
        try:
            for m in self.tail.read():
                self.listener.feed(m)
        except NotATlog:
            self.broken = True

    def finish(self) -> None:
        """bridge.tlog is finished: the rest, then the drawings (left out if they fail)."""
        try:
            self.poll()
            self.tail.close()
            if self.broken or not self.tail.complete:
                draw_frames(self.dir)       # its reader copes with what is not whole frames
            else:
                write_frames(self.dir, self.listener.buffer, self.listener.newest_stamp)
        except Exception:  # noqa: BLE001
            pass


def live_frames(run_dir: Path, priority: Priority | None, conn) -> None:
    """A sub-helper's main: read bridge.tlog every POLL_S wall s until the parent says the flight
    is over (anything sent), then draw; nothing when the pipe closes first (the run was given up)."""
    try:
        frames = LiveFrames(run_dir)
        while not conn.poll(POLL_S):
            frames.poll()
        conn.recv()
    except (EOFError, OSError):
        return
    except Exception:  # noqa: BLE001 - drawn from the finished file below
        frames = None
    if priority is not None:
        priority.restore()      # the drawing is on the run's critical path now
    if frames is None:
        draw_frames(Path(run_dir))
    else:
        frames.finish()
