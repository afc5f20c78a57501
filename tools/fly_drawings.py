"""The drawings of a `towerlink fly` run: tracks.png and the frame tree (frames.pdf, frames.png, frames.yaml).

:class:`Drawings` draws them here, after the scoring (where fork is not available, or for a
Launch driven by a test). :class:`DrawingWorker` is a child forked when the run starts
(tools.fly_child): once the run flies (:meth:`DrawingWorker.flight_begins`: not during the
start-up, when the world's imports need the cores) it imports matplotlib (about half a second of
CPU), forks a sub-helper for the frame tree (tools.fly_frames) and, like it, reads the tlogs as
they grow. Once the flight is over it hands the launcher the run's data (the launcher's scoring
needs them: :meth:`DrawingWorker.run_data`) and draws tracks.png at once, while the sub-helper
draws the frame tree. Either draws a picture as far as it goes: a drawing that fails is left out
and never hides the summary.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

from tools.fly_child import POLL_S, ForkedHelper, Priority, SubHelper
from tools.fly_frames import draw_frames, live_frames, prepare_pdf


def draw_tracks(run_dir: Path, scenario: str | None, data) -> None:
    """tracks.png from the run's data (tools.run_data.RunData); left out if it fails."""
    try:
        from tools.plot_tracks import plot_run
        plot_run(run_dir, scenario=scenario, data=data)
    except Exception:  # noqa: BLE001 - a plot failure must not hide the summary
        pass


class Drawings:
    """Both drawings in this process, once the run's data are in (:meth:`tracks`)."""

    def __init__(self, run_dir: Path, scenario: str | None) -> None:
        self.dir = Path(run_dir)
        self.scenario = scenario

    def flight_begins(self) -> None:
        """The sim clock moved (nothing to prepare here)."""

    def flight_over(self) -> None:
        """The tlogs are complete (nothing to do here: both are drawn in :meth:`tracks`)."""

    def run_data(self):
        """The run's data (tools.run_data.RunData) if they were read while the run flew (tracks.png
        is then drawn from them without :meth:`tracks`); None here: the caller reads them."""
        return None

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

    The parent calls :meth:`flight_begins` when the sim clock first moves (the child then imports
    what it draws with and reads the tlogs as they grow), :meth:`flight_over` once the processes
    stopped, :meth:`run_data` for the run's data (or, None, :meth:`tracks` with the data it read
    itself), :meth:`wait` for the pictures; :meth:`close` (always, also on failure or Ctrl-C)
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

    def run_data(self):
        return self.helper.ask(("data",))

    def tracks(self, data) -> None:
        self.helper.send(("tracks", data))

    def wait(self) -> None:
        self.helper.send(None)
        self.helper.wait()

    def close(self) -> None:
        self.helper.close()


def _worker(run_dir: Path, scenario: str | None, conn) -> None:
    """The child: prepare at a low priority, then do what the parent asks for until None. Once
    prepared it reads the run's data while the tlogs grow (tools.run_data_tail) and forks a
    sub-helper (tools.fly_frames.live_frames) that reads bridge.tlog likewise and draws the frame
    tree, while this one draws tracks.png: after the flight only the last slices are read, and the
    two drawings are made side by side."""
    priority = None
    frames: SubHelper | None = None
    live = None
    try:
        while True:
            try:
                while live is not None and not conn.poll(POLL_S):
                    live = _poll(live)
                job = conn.recv()
            except (EOFError, OSError):
                return
            if job is None:
                return
            if job[0] == "prepare":
                priority = Priority()   # lowered only while the run flies: it may not come back up
                _prepare()
                frames = SubHelper(partial(live_frames, run_dir, priority))    # shares the imports
                live = _live_data(run_dir)
                continue
            if priority is not None:
                priority.restore()      # the drawings are on the run's critical path now
            if job[0] == "frames":
                if frames is not None:
                    frames.send("over")
                else:
                    draw_frames(run_dir)
            elif job[0] == "data":
                data, live = _finish(live), None
                conn.send(data)         # None: the parent reads the tlogs and sends them (tracks)
                if data is not None:
                    draw_tracks(run_dir, scenario, data)
            elif job[0] == "tracks":
                draw_tracks(run_dir, scenario, job[1])
    finally:
        if frames is not None:
            frames.wait()       # its drawing done (or, the run given up, left out)


def _live_data(run_dir: Path):
    """The run's data read as the tlogs grow (tools.run_data_tail.LiveRunData); None if that fails."""
    try:
        from tools.run_data_tail import LiveRunData
        return LiveRunData(run_dir)
    except Exception:  # noqa: BLE001 - the parent then reads the finished tlogs
        return None


def _poll(live):
    """`live` after a read of what the tlogs gained; None if that failed."""
    try:
        live.poll()
        return live
    except Exception:  # noqa: BLE001
        return None


def _finish(live):
    """The run's data from `live` (the tlogs are finished); None without them."""
    if live is None:
        return None
    try:
        return live.finish()
    except Exception:  # noqa: BLE001
        return None


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
