"""The drawings of a `towerlink fly` run: tracks.png and the frame tree (frames.pdf, frames.png, frames.yaml).

:class:`Drawings` draws them here, after the scoring (where fork is not available, or for a
Launch driven by a test). :class:`DrawingWorker` is a child forked when the run starts: it
imports matplotlib (about half a second of CPU) while the run flies, at a lower CPU priority
so that the lockstep chain keeps the cores; once the flight is over it draws the frame tree
from bridge.tlog at once and tracks.png as soon as the parent hands it the run's data, both in
parallel with the parent's scoring. Either draws a picture as far as it goes: a drawing that
fails is left out and never hides the summary.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
from pathlib import Path

#: the worker's niceness while the run flies: it takes what the lockstep chain leaves idle
WORKER_NICE = 10
#: wall s the parent waits for the worker's drawings before it stops it and goes on without them
WORKER_TIMEOUT = 120.0


def draw_tracks(run_dir: Path, scenario: str | None, data) -> None:
    """tracks.png from the run's data (tools.run_data.RunData); left out if it fails."""
    try:
        from tools.plot_tracks import plot_run
        plot_run(run_dir, scenario=scenario, data=data)
    except Exception:  # noqa: BLE001 - a plot failure must not hide the summary
        pass


def draw_frames(run_dir: Path) -> None:
    """frames.pdf, frames.png and frames.yaml from bridge.tlog's transforms; left out if it fails
    or the bridge recorded no transform."""
    try:
        from tools.view_frames import buffer_from_tlog, write_drawing
        buf, now = buffer_from_tlog(run_dir / "bridge.tlog")
        if buf.edge_stats():
            title = f"view_frames: {run_dir.name}"
            write_drawing(buf, run_dir / "frames.pdf", now=now, title=title)
            write_drawing(buf, run_dir / "frames.png", now=now, title=title)
    except Exception:  # noqa: BLE001
        pass


class Drawings:
    """Both drawings in this process, once the run's data are in (:meth:`tracks`)."""

    def __init__(self, run_dir: Path, scenario: str | None) -> None:
        self.dir = Path(run_dir)
        self.scenario = scenario

    def flight_over(self) -> None:
        """The tlogs are complete (nothing to do here: both are drawn in :meth:`tracks`)."""

    def tracks(self, data) -> None:
        """Draw tracks.png from `data`, then the frame tree."""
        draw_tracks(self.dir, self.scenario, data)
        draw_frames(self.dir)

    def wait(self) -> None:
        """Both drawings are written (or left out)."""

    def close(self) -> None:
        """Nothing to stop."""


class DrawingWorker(Drawings):
    """The drawings in a child forked by :meth:`start`, before the launcher starts any thread.

    The parent calls :meth:`flight_over` once the processes stopped, :meth:`tracks` with the
    run's data, :meth:`wait` for the pictures; :meth:`close` (always, also on failure or Ctrl-C)
    stops the child if it still runs and reaps it."""

    def __init__(self, run_dir: Path, scenario: str | None) -> None:
        super().__init__(run_dir, scenario)
        self._conn = None
        self._child: multiprocessing.Process | None = None

    @staticmethod
    def available() -> bool:
        return "fork" in multiprocessing.get_all_start_methods()

    def start(self) -> None:
        ctx = multiprocessing.get_context("fork")
        here, there = ctx.Pipe(duplex=False)
        from tools.procs import die_with_parent
        self._child = ctx.Process(target=_worker, args=(here, self.dir, self.scenario, die_with_parent()),
                                  name="fly-drawings", daemon=True)
        self._child.start()
        here.close()
        self._conn = there

    def _send(self, job) -> None:
        try:
            self._conn.send(job)
        except (OSError, ValueError, AttributeError):     # the child is gone: its pictures are left out
            pass

    def flight_over(self) -> None:
        self._send(("frames",))

    def tracks(self, data) -> None:
        self._send(("tracks", data))
        self._send(None)

    def wait(self) -> None:
        if self._child is not None:
            self._child.join(WORKER_TIMEOUT)
        self.close()

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        child, self._child = self._child, None
        if child is None:
            return
        if child.is_alive():
            child.terminate()
            child.join(5.0)
            if child.is_alive():
                child.kill()
        child.join()


def _worker(conn, run_dir: Path, scenario: str | None, with_parent) -> None:
    """The child: prepare at a low priority, then draw what the parent asks for until None.
    `with_parent`: tools.procs.die_with_parent()'s hook, made in the parent (None: none)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # a Ctrl-C is the parent's to handle: it stops us
    if with_parent is not None:
        with_parent()       # SIGTERM when the launcher dies outright
    base = os.getpriority(os.PRIO_PROCESS, 0)
    try:
        os.setpriority(os.PRIO_PROCESS, 0, base + WORKER_NICE)
    except OSError:
        pass
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401 - the import is the point: paid while the run flies
        import tools.plot_tracks  # noqa: F401
        import tools.view_frames  # noqa: F401
    except Exception:  # noqa: BLE001 - the drawings then fail (and are left out) when asked for
        pass
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        try:    # the drawings are on the run's critical path now: back to the parent's priority
            os.setpriority(os.PRIO_PROCESS, 0, base)
        except OSError:     # not allowed to lower our niceness: drawn at the lower priority
            pass
        if job[0] == "frames":
            draw_frames(run_dir)
        elif job[0] == "tracks":
            draw_tracks(run_dir, scenario, job[1])
