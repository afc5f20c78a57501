"""A vehicle's logs as the MAVLink log download sees them (vehicle/logs/transfer.py's
catalog): listed oldest first with the size they will have, read as their bytes reach the
disk, erased in order with the writes still queued.

The writer thread may still hold chunks of a log (the open one, one just closed): such a
log is listed with what it recorded so far, and a read of bytes not on disk yet answers
None (the download asks again next tick) instead of a short read that would end it.
"""
from __future__ import annotations

from vehicle.logs.log_session import LogSession
from vehicle.logs.store import LogInfo, LogStore
from vehicle.logs.writer import LogWriter


class LogCatalog:
    """The logs of one store, with the sessions whose bytes are still on their way."""

    def __init__(self, store: LogStore, writer: LogWriter) -> None:
        self.store = store
        self.writer = writer
        self._unwritten: dict[int, LogSession] = {}     # log number -> its session
        self._erasing = 0                                # erases queued, not done yet
        self._listed: list[LogInfo] = []

    def track(self, session: LogSession) -> None:
        """A log just opened: list it with the size it will have until it is on disk."""
        self._unwritten[int(session.path.stem)] = session

    def busy(self) -> set[int]:
        """Numbers of the logs whose bytes may still be on their way to the disk."""
        return set(self._unwritten)

    @property
    def erasing(self) -> bool:
        """An erase is queued on the writer and not done yet."""
        return self._erasing > 0

    def entries(self) -> list[LogInfo]:
        """The logs oldest first (none while an erase is under way)."""
        if self._erasing:
            self._listed = []
            return self._listed
        for s in self._unwritten.values():
            if not s.closed:
                s.hand_over()              # what the open log recorded up to now
        listed = self.store.entries()
        unwritten = self._unwritten
        for k, e in enumerate(listed):
            s = unwritten.get(e.num)
            if s is None:
                continue
            if e.size >= s.bytes and s.closed:
                del unwritten[e.num]            # on disk whole: no longer tracked
            elif s.bytes > e.size:
                listed[k] = LogInfo(e.num, s.bytes, e.mtime)
        self._listed = listed
        return listed

    def read(self, list_id: int, ofs: int, count: int) -> bytes | None:
        """Up to `count` bytes of list entry `list_id` (as last listed) from `ofs`; None when
        they are recorded but not on disk yet."""
        listed = self._listed or self.entries()
        if not 1 <= list_id <= len(listed):
            return b""
        num = listed[list_id - 1].num
        data = self.store.read(num, ofs, count)
        s = self._unwritten.get(num)
        if s is not None and len(data) < count and ofs + len(data) < s.bytes:
            return None
        return data

    def erase(self) -> None:
        """Erase every log on the writer thread, after what is queued (close the open log
        first: a chunk queued for it must not bring it back)."""
        self._erasing += 1
        store = self.store

        def erase_all() -> None:
            try:
                store.erase()
            finally:
                self._erasing -= 1
        self.writer.call(erase_all)
        self._listed = []
        self._unwritten.clear()
