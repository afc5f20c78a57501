"""A run's data (tools.run_data.RunData) read while the run flies: the tlogs folded as they grow.

tools.run_data.load_run reads the finished vehicles.tlog, then bridge.tlog (its own messages),
each folded on its own. :class:`LiveRunData` folds the same messages of the same files in the
same order (tools.tlog_tail, tools.run_data.RunFold), a slice at a time (:meth:`poll`), so once
the flight is over only the last slice is left (:meth:`finish`): the same RunData. A tlog that
is not whole stamped frames is read by load_run instead (its robust reader).
"""
from __future__ import annotations

from pathlib import Path

from tools.run_data import BRIDGE_OWN, RunData, RunFold, folded_types, load_run
from tools.tlog_tail import NotATlog, TlogTail


class LiveRunData:
    """run_dir's vehicles.tlog and bridge.tlog, folded while they grow."""

    def __init__(self, run_dir: str | Path) -> None:
        self.dir = Path(run_dir)
        self.data = RunData()
        # vehicles.tlog first, then bridge.tlog's own messages (the rest repeats the vehicles'), as load_run
        self.parts = [(TlogTail(self.dir / "vehicles.tlog", folded_types()), RunFold(self.data)),
                      (TlogTail(self.dir / "bridge.tlog", BRIDGE_OWN), RunFold(self.data))]
        self.broken = False         # a tlog was not whole frames: the finished files are read instead

    def poll(self) -> None:
        """Fold what the tlogs gained."""
        if self.broken:
            return
        try:
            for tail, fold in self.parts:
                fold.feed(tail.read())
        except NotATlog:
            self.broken = True

    def finish(self) -> RunData:
        """The tlogs are finished: the rest folded; the run's data."""
        self.poll()
        for tail, _fold in self.parts:
            tail.close()
        if self.broken or not all(tail.complete for tail, _fold in self.parts) \
                or not (self.dir / "vehicles.tlog").exists():
            return load_run(self.dir)
        for _tail, fold in self.parts:
            fold.finish()
        return self.data
