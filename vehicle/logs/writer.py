"""The one place logs touch the disk while a world runs: a background thread that
appends chunks of log bytes to their files.

The step loop never waits on it: `write(path, data)` only appends to a deque and returns.
The queue is bounded by bytes (`max_pending`): a chunk that does not fit is dropped whole
and counted (ArduPilot counts the writes its full buffer refuses the same way), so a slow
disk costs log data, never sim time. Chunks are whole records, so a reader skips a
dropped chunk cleanly.

Each chunk is appended with its own open / write / close: no file handle is held between
chunks (a 1,000-vehicle world would otherwise hold 1,000 open logs), and whatever was
written is the OS's, so a crash of the process loses only chunks still queued.
`close(path)` also fsyncs the file; `call(fn)` runs fn on the thread in queue order (erasing
and discarding logs: a chunk still queued for a file must not bring it back). `flush()`
waits until everything queued so far is done (tests, stopping).
"""
from __future__ import annotations

import threading
import time
import traceback
from collections import deque
from collections.abc import Callable

from vehicle.files.durable import fsync_path

MAX_PENDING = 64 * 1024 * 1024          # bytes queued before chunks are dropped
WAKE_BYTES = 256 * 1024                 # producers wake the thread when this much waits
IDLE_WAIT = 0.05                        # s the thread sleeps when nobody woke it


class LogWriter:
    """Appends queued chunks to files on a daemon thread (started on first use)."""

    def __init__(self, max_pending: int = MAX_PENDING) -> None:
        self.max_pending = max_pending
        self._q: deque = deque()
        self._wake = threading.Event()
        self._idle = threading.Condition()
        self._thread: threading.Thread | None = None
        self._stopping = False
        # counters, each written by one thread only (no lock needed)
        self.queued = 0            # bytes accepted (producer)
        self.written = 0           # bytes written (writer thread)
        self.failed = 0            # bytes the OS refused (writer thread)
        self.dropped = 0           # bytes dropped because the queue was full (producer)
        self._done_items = 0       # items the thread has finished (writer thread)
        self._items = 0            # items queued (producer)
        self.cpu = 0.0             # CPU seconds the writer thread spent writing (writer thread)

    @property
    def pending(self) -> int:
        """Bytes queued and not yet written."""
        return self.queued - self.written - self.failed

    def write(self, path: str, data: bytes) -> bool:
        """Queue `data` to be appended to `path`; False (and counted) when the queue is full."""
        n = len(data)
        if self.pending + n > self.max_pending:
            self.dropped += n
            return False
        self.queued += n
        self._put(("w", path, data))
        if self.pending >= WAKE_BYTES:
            self._wake.set()
        return True

    def close(self, path: str) -> None:
        """After what is queued for `path`: fsync it (the log is complete)."""
        self._put(("c", path, None))
        self._wake.set()

    def call(self, fn: Callable[[], None]) -> None:
        """Run fn() on the writer thread after everything queued before it."""
        self._put(("f", fn, None))
        self._wake.set()

    def _put(self, item) -> None:
        if self._thread is None:
            self._start()
        self._items += 1
        self._q.append(item)

    def _start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="towerlink-logwriter", daemon=True)
        self._thread.start()

    def flush(self, timeout: float = 10.0) -> bool:
        """Wait until everything queued so far is written; False on timeout."""
        if self._thread is None:
            return True
        target = self._items
        self._wake.set()
        with self._idle:
            return self._idle.wait_for(lambda: self._done_items >= target, timeout)

    def stop(self, timeout: float = 10.0) -> None:
        """Write what is queued, then end the thread."""
        self.flush(timeout)
        self._stopping = True
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout)
            self._thread = None
            self._stopping = False

    def _run(self) -> None:
        q = self._q
        while True:
            self._wake.wait(IDLE_WAIT)
            self._wake.clear()
            c0 = time.thread_time()
            while q:
                kind, path, data = q.popleft()
                if kind == "w":
                    self._append(path, data)
                elif kind == "c":
                    fsync_path(path)
                else:
                    try:
                        path()
                    except Exception:  # noqa: BLE001 - a failed erase must not end the writer
                        traceback.print_exc()
                self._done_items += 1
            self.cpu += time.thread_time() - c0
            with self._idle:
                self._idle.notify_all()
            if self._stopping and not q:
                return

    def _append(self, path: str, data: bytes) -> None:
        try:
            with open(path, "ab", buffering=0) as f:
                f.write(data)
            self.written += len(data)
        except OSError:
            self.failed += len(data)

