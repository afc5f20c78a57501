"""run.mcap made while the run flies: the tlogs read as they grow, the Foxglove records built and encoded as they come.

tools.run_mcap.write_run_mcap reads the finished tlogs after the flight; :class:`LiveRecording`
makes the same file (byte for byte) from the same messages in the same order, but does the
work in slices while the tlogs are still being written (:meth:`LiveRecording.poll`), so after
the flight only the last slice and the writing are left (:meth:`LiveRecording.finish`). If a
tlog turns out not to be whole stamped frames, the finished tlogs are read by write_run_mcap
instead (its robust reader).
"""
from __future__ import annotations

from pathlib import Path

from common.mavlink.ids import TOWER_SYSID
from tools.run_mcap import RUN_MCAP, encode, write_encoded, write_run_mcap
from tools.scene_feed import FED_TYPES, SceneFeed
from tools.tlog_stamped import StampedDecoder
from tools.tlog_tail import NotATlog, TlogTail


class StableMerge:
    """Two message streams that arrive in pieces, merged by their ``_timestamp`` exactly as
    heapq.merge merges the whole streams (a tie goes to the first stream)."""

    def __init__(self) -> None:
        self.queues: tuple[list, list] = ([], [])
        self._heads = [0, 0]

    def add(self, k: int, msgs: list) -> None:
        self.queues[k].extend(msgs)

    def take(self, final: bool = False) -> list:
        """The messages whose place is settled: while both streams have one waiting (`final`:
        the streams have ended, all of them)."""
        a, b = self.queues
        i, j = self._heads
        out = []
        while i < len(a) and j < len(b):
            if getattr(b[j], "_timestamp", 0.0) < getattr(a[i], "_timestamp", 0.0):
                out.append(b[j])
                j += 1
            else:
                out.append(a[i])
                i += 1
        if final:
            out += a[i:] + b[j:]
            i, j = len(a), len(b)
        del a[:i], b[:j]
        self._heads = [0, 0]
        return out


class LiveRecording:
    """run_dir/run.mcap from bridge.tlog and the tower's own sends in tower.tlog, built as they grow."""

    def __init__(self, run_dir: str | Path) -> None:
        self.dir = Path(run_dir)
        scene = StampedDecoder(FED_TYPES)      # decoded as far as the feed reads them, as write_run_mcap's
        self.tails = (TlogTail(self.dir / "bridge.tlog", scene=scene),
                      TlogTail(self.dir / "tower.tlog", sysids=(TOWER_SYSID,), scene=scene))
        self.merge = StableMerge()
        self.feed = SceneFeed()
        self.records: list[tuple[int, str, bytes]] = []
        self.broken = False         # a tlog was not whole frames: the finished files are read instead

    def poll(self, final: bool = False) -> None:
        """Read what the tlogs gained and record what is settled (`final`: the tlogs are finished)."""
        if self.broken:
            return
        try:
            for k, tail in enumerate(self.tails):
                self.merge.add(k, tail.read())
        except NotATlog:
            self.broken = True
            return
        if final and not all(t.complete for t in self.tails):
            self.broken = True      # a cut frame at the end: not a whole tlog
            return
        for m in self.merge.take(final):
            self.records += [encode(r) for r in self.feed.feed(m)]

    def finish(self) -> Path:
        """The tlogs are finished: the rest, then run.mcap written; returns its path."""
        self.poll(final=True)
        for t in self.tails:
            t.close()
        if self.broken:
            return write_run_mcap(self.dir)
        out = self.dir / RUN_MCAP
        write_encoded(self.records, out)
        return out
