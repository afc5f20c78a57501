"""run.mcap of a `towerlink fly` run, recorded while it flies (tools.run_recording) in a child forked at launch.

From when the sim clock first moves, every POLL_S wall s while the run flies, the child reads what bridge.tlog and tower.tlog
gained and turns it into Foxglove records, at a lower CPU priority (tools.fly_child); when the
flight is over (:meth:`Recorder.flight_over`) it reads the rest and writes run.mcap, the same
file tools.run_mcap.write_run_mcap writes from the finished tlogs. A recording that fails is
left out and never hides the summary.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

from tools.fly_child import ForkedHelper, Priority

#: wall s between the child's reads of the growing tlogs
POLL_S = 0.25


class Recorder:
    """The recording child: :meth:`start` before the launcher starts any thread, :meth:`flight_begins`
    when the sim clock first moves (this run's tlogs are open then: an earlier run's in the same
    folder are not read; and the world's start-up is over, which needs the cores), :meth:`flight_over`
    once the processes stopped (the tlogs are complete), :meth:`wait` for run.mcap,
    :meth:`close` always."""

    def __init__(self, run_dir: Path) -> None:
        self.helper = ForkedHelper("fly-recorder", partial(_record, Path(run_dir)))

    available = staticmethod(ForkedHelper.available)

    def start(self) -> None:
        self.helper.start()

    def flight_begins(self) -> None:
        self.helper.send("start")

    def flight_over(self) -> None:
        self.helper.send("finish")

    def wait(self) -> None:
        self.helper.wait()

    def close(self) -> None:
        self.helper.close()


def _record(run_dir: Path, conn) -> None:
    priority = None
    rec = None
    try:
        job = conn.recv()
        if job == "start":
            priority = Priority()       # lowered only while the run flies: it may not come back up
            rec = _recording(run_dir)
            while not conn.poll(POLL_S):    # a read of the tlogs, then wait for more (or the end)
                rec.poll()
            job = conn.recv()
        if job != "finish":
            return
    except (EOFError, OSError):
        return
    except Exception:  # noqa: BLE001 - recorded from the finished tlogs below
        if rec is not None:
            rec.broken = True
    if priority is not None:
        priority.restore()      # run.mcap is on the run's critical path now
    try:
        (rec or _recording(run_dir)).finish()
    except Exception:  # noqa: BLE001 - the recording must not hide the summary
        pass


def _recording(run_dir: Path):
    from tools.run_recording import LiveRecording
    try:
        import mcap.writer  # noqa: F401 - paid while the run flies
    except ImportError:
        pass
    return LiveRecording(run_dir)
