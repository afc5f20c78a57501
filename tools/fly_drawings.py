"""The drawings of a `towerlink fly` run: tracks.png and the frame tree (frames.pdf, frames.png, frames.yaml).

:class:`Drawings` draws them here, after the scoring (where fork is not available, or for a
Launch driven by a test). :class:`DrawingWorker` is a child forked when the run starts
(tools.fly_child): it imports matplotlib (about half a second of CPU) once the run flies
(:meth:`DrawingWorker.flight_begins`: not during the start-up, when the world's imports need
the cores) and then forks a sub-helper that shares those imports (tools.fly_frames); once the
flight is over the sub-helper draws the frame tree from bridge.tlog at once while the child draws
tracks.png as soon as the parent hands it the run's data: the two side by side, and beside the
parent's scoring. Nothing is read while the run flies: a helper's CPU then slows the lockstep
chain down. Either draws a picture as far as it goes: a drawing that fails is left out and never
hides the summary.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

from tools.fly_child import ForkedHelper, Priority, SubHelper
from tools.fly_frames import draw_frames, frames_when_over, prepare_pdf


def draw_tracks(run_dir: Path, scenario: str | None, data) -> None:
    """tracks.png from the run's data (tools.run_data.RunData); left out if it fails."""
    try:
        from tools.plot_tracks import plot_run
        plot_run(run_dir, scenario=scenario, data=data)
    except Exception:  # noqa: BLE001 - a plot failure must not hide the summary
        pass


class Drawings:
    """Both drawings in this process, once the run's data are in (:meth:`tracks`); `bridge`:
    bridge.tlog's messages, already read (tools.fly_frames.draw_frames)."""

    def __init__(self, run_dir: Path, scenario: str | None, bridge: list | None = None) -> None:
        self.dir = Path(run_dir)
        self.scenario = scenario
        self.bridge = bridge

    def flight_begins(self) -> None:
        """The sim clock moved (nothing to prepare here)."""

    def flight_over(self) -> None:
        """The tlogs are complete (nothing to do here: both are drawn in :meth:`tracks`)."""

    def tracks(self, data) -> None:
        """Draw tracks.png from `data`, then the frame tree."""
        draw_tracks(self.dir, self.scenario, data)
        draw_frames(self.dir, self.bridge)

    def wait(self) -> None:
        """Both drawings are written (or left out)."""

    def close(self) -> None:
        """Nothing to stop."""


class DrawingWorker(Drawings):
    """The drawings in a child forked by :meth:`start`, before the launcher starts any thread.

    The parent calls :meth:`flight_begins` when the sim clock first moves (the child then imports
    what it draws with), :meth:`flight_over` once the processes stopped, :meth:`tracks` with the
    run's data, :meth:`wait` for the pictures; :meth:`close` (always, also on failure or Ctrl-C)
    stops the child if it still runs and reaps it."""

    def __init__(self, run_dir: Path, scenario: str | None) -> None:
        super().__init__(run_dir, scenario)
        self.helper = ForkedHelper("fly-drawings", partial(_worker, self.dir, self.scenario))

    available = staticmethod(ForkedHelper.available)

    def start(self) -> None:
        self.helper.start()

    def flight_begins(self) -> None:
        self.helper.send(("prepare",))

    def flight_over(self) -> None:
        self.helper.send(("frames",))

    def tracks(self, data) -> None:
        self.helper.send(("tracks", data))
        self.helper.send(None)

    def wait(self) -> None:
        self.helper.wait()

    def close(self) -> None:
        self.helper.close()


def _worker(run_dir: Path, scenario: str | None, conn) -> None:
    """The child: prepare at a low priority (and fork the frame tree's sub-helper), then draw what
    the parent asks for until None."""
    priority = None
    frames: SubHelper | None = None
    try:
        while True:
            try:
                job = conn.recv()
            except (EOFError, OSError):
                return
            if job is None:
                return
            if job[0] == "prepare":
                priority = Priority()   # lowered only while the run flies: it may not come back up
                _prepare()
                frames = SubHelper(partial(frames_when_over, run_dir, priority))    # shares the imports
                continue
            if priority is not None:
                priority.restore()      # the drawings are on the run's critical path now
            if job[0] == "frames":
                if frames is not None:
                    frames.send("over")     # the sub-helper draws it, beside tracks.png here
                else:
                    draw_frames(run_dir)
            elif job[0] == "tracks":
                draw_tracks(run_dir, scenario, job[1])
    finally:
        if frames is not None:
            frames.wait()       # its drawing done (or, the run given up, left out)


def _prepare() -> None:
    """Import what the drawings need (paid while the run flies, on what the lockstep leaves idle)."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
        import tools.plot_tracks  # noqa: F401
        import tools.view_frames  # noqa: F401
        prepare_pdf()
    except Exception:  # noqa: BLE001 - the drawings then fail (and are left out) when asked for
        pass
