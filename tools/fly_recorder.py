"""run.mcap of a `towerlink fly` run, recorded while it flies (tools.run_recording) in a child forked at launch.

Every POLL_S wall s while the run flies, the child reads what bridge.tlog and tower.tlog
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
    """The recording child: :meth:`start` before the launcher starts any thread, :meth:`run_started`
    once this run's tlogs are open (an earlier run's in the same folder are not read), :meth:`flight_over`
    once the processes stopped (the tlogs are complete), :meth:`wait` for run.mcap,
    :meth:`close` always."""

    def __init__(self, run_dir: Path) -> None:
        self.helper = ForkedHelper("fly-recorder", partial(_record, Path(run_dir)))

    available = staticmethod(ForkedHelper.available)

    def start(self) -> None:
        self.helper.start()

    def run_started(self) -> None:
        self.helper.send("start")

    def flight_over(self) -> None:
        self.helper.send("finish")

    def wait(self) -> None:
        self.helper.wait()

    def close(self) -> None:
        self.helper.close()


def _record(run_dir: Path, conn) -> None:
    priority = Priority()
    from tools.run_recording import LiveRecording
    try:
        import mcap.writer  # noqa: F401 - paid while the run flies
    except ImportError:
        pass
    rec = LiveRecording(run_dir)
    try:
        job = conn.recv()
        if job == "start":
            while not conn.poll(POLL_S):    # a read of the tlogs, then wait for more (or the end)
                rec.poll()
            job = conn.recv()
        if job != "finish":
            return
    except (EOFError, OSError):
        return
    except Exception:  # noqa: BLE001 - recorded from the finished tlogs below
        rec.broken = True
    priority.restore()      # run.mcap is on the run's critical path now
    try:
        rec.finish()
    except Exception:  # noqa: BLE001 - the recording must not hide the summary
        pass
