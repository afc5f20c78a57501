"""The MAVLink log download protocol as ArduPilot serves it
(libraries/AP_Logger/AP_Logger_MAVLinkLogTransfer.cpp): LOG_REQUEST_LIST -> LOG_ENTRY,
LOG_REQUEST_DATA -> LOG_DATA, LOG_REQUEST_END, LOG_ERASE.

Pure: messages in, messages out. `handle(msg, channel, armed)` and `pump(armed)` (once a
tick) return (message, channel) pairs for the caller to send on that channel only; the
logs come from a catalog it is given (entries oldest first, read, erase).

- Armed: every request is ignored; the first one of an armed period gets STATUSTEXT
  ERROR "Disarm for log download". A transfer under way pauses while armed.
- List: entries are numbered 1..N from the oldest log; no logs -> exactly one LOG_ENTRY
  with id 0, num_logs 0, last_log_num 0, time_utc 0, size 0. `start` below 1 counts as 1,
  `end` above N as N (0xFFFF is the usual "all").
- Data: a bad id (0 or above N) cancels any transfer, no reply. Otherwise LOG_DATA of 90
  bytes each (the last shorter, zero-padded) from `ofs` for min(count, size - ofs) bytes;
  a packet shorter than 90 bytes or the last of the asked range ends the transfer;
  `ofs` at or past the end -> one LOG_DATA with count 0. Up to SENDS_PER_PUMP packets go
  out per call (ArduPilot SITL sends 40 per logging-thread pass); gaps are the client's
  to ask for again.
- One transfer at a time: a list or data request from another channel while one is under
  way gets STATUSTEXT INFO "Log download in progress"; a data request on the same channel
  is dropped (MAVProxy streams its gap-filling requests).
- End: stop, no reply. Erase: the catalog erases every log, no reply.

Not modelled: ArduPilot also holds a transfer while the requesting link has not heard a
GCS heartbeat for 3 s, and paces by the link's free transmit space.
"""
from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Protocol

from pymavlink.dialects.v20 import ardupilotmega as mav

DATA_LEN = 90                # LOG_DATA.data
SENDS_PER_PUMP = 40


class LogEntryInfo(Protocol):
    size: int
    mtime: int


class LogCatalog(Protocol):
    """What the protocol needs of the logs: the list oldest first (sizes as they will be),
    their bytes, erasing."""

    def entries(self) -> Sequence[LogEntryInfo]: ...

    def read(self, list_id: int, ofs: int, count: int) -> bytes | None:
        """None: those bytes exist but cannot be read yet (asked again at the next pump)."""

    def erase(self) -> None: ...


Out = list[tuple[object, Hashable]]


class LogTransfer:
    """One vehicle's log-download state machine (ArduPilot's LoggerThread transfer part)."""

    IDLE, LISTING, SENDING = "idle", "listing", "sending"

    def __init__(self, catalog: LogCatalog) -> None:
        self.catalog = catalog
        self.activity = self.IDLE
        self.channel: Hashable | None = None      # the link a transfer answers on
        self._warned_armed = False
        self._next = self._last = self._num_logs = 0
        self._data_id = 0
        self._data_size = self._ofs = self._remaining = 0

    # ----- requests ---------------------------------------------------------------------
    def handle(self, m, channel: Hashable, armed: bool) -> Out:
        """Answer one LOG_REQUEST_LIST / LOG_REQUEST_DATA / LOG_REQUEST_END / LOG_ERASE."""
        if armed:
            if self._warned_armed:
                return []
            self._warned_armed = True
            return [(_text(mav.MAV_SEVERITY_ERROR, "Disarm for log download"), channel)]
        self._warned_armed = False
        kind = m.get_type()
        if kind == "LOG_REQUEST_LIST":
            return self._request_list(channel, m.start, m.end)
        if kind == "LOG_REQUEST_DATA":
            return self._request_data(channel, m.id, m.ofs, m.count)
        if kind == "LOG_REQUEST_END":
            self.end()
        elif kind == "LOG_ERASE":
            self.catalog.erase()
        return []

    def end(self) -> None:
        """Stop whatever transfer is under way (LOG_REQUEST_END, the link went away)."""
        self.activity = self.IDLE
        self.channel = None

    def _busy(self, channel: Hashable) -> Out:
        return [(_text(mav.MAV_SEVERITY_INFO, "Log download in progress"), channel)]

    def _request_list(self, channel: Hashable, start: int, end: int) -> Out:
        if self.channel is not None:
            return self._busy(channel)
        self._num_logs = len(self.catalog.entries())
        if self._num_logs == 0:
            self._next = self._last = 0
        else:
            self._next = max(start, 1)
            self._last = min(end, self._num_logs)
        self.activity, self.channel = self.LISTING, channel
        return self._send_listing()

    def _request_data(self, channel: Hashable, list_id: int, ofs: int, count: int) -> Out:
        if self.channel is not None:
            return [] if channel == self.channel else self._busy(channel)
        if self.activity != self.SENDING or self._data_id != list_id:
            entries = self.catalog.entries()
            if not 1 <= list_id <= len(entries):
                self.activity = self.IDLE          # an invalid log: cancel, no reply
                return []
            self._data_id = list_id
            self._data_size = entries[list_id - 1].size
        self._ofs = ofs
        self._remaining = min(count, max(0, self._data_size - ofs))
        self.activity, self.channel = self.SENDING, channel
        return self._send_data()

    # ----- sending ---------------------------------------------------------------------
    def pump(self, armed: bool) -> Out:
        """Continue a list or a download (call once a tick); nothing while armed."""
        if self.channel is None or armed:
            return []
        if self.activity == self.LISTING:
            return self._send_listing()
        if self.activity == self.SENDING:
            return self._send_data()
        return []

    def _send_listing(self) -> Out:
        out: Out = []
        entries = self.catalog.entries() if self._next else []
        ch = self.channel
        for _ in range(SENDS_PER_PUMP):
            n = self._next
            size = mtime = 0
            if n and n <= len(entries):
                size, mtime = entries[n - 1].size, entries[n - 1].mtime
            out.append((mav.MAVLink_log_entry_message(n, self._num_logs, self._last, mtime, size), ch))
            if n >= self._last:
                self.end()
                break
            self._next += 1
        return out

    def _send_data(self) -> Out:
        out: Out = []
        ch, list_id = self.channel, self._data_id
        want = min(self._remaining, SENDS_PER_PUMP * DATA_LEN)
        data = self.catalog.read(list_id, self._ofs, want) if want else b""
        if data is None:                 # recorded, not on disk yet: again next pump
            return out
        pos = 0
        for _ in range(SENDS_PER_PUMP):
            chunk = data[pos:pos + min(DATA_LEN, self._remaining)]
            pos += len(chunk)
            n = len(chunk)
            out.append((mav.MAVLink_log_data_message(list_id, self._ofs, n,
                                                     list(chunk) + [0] * (DATA_LEN - n)), ch))
            self._ofs += n
            self._remaining -= n
            if n < DATA_LEN or self._remaining == 0:
                self.end()
                break
        return out


def _text(severity: int, text: str):
    return mav.MAVLink_statustext_message(severity, text.encode("ascii"), 0, 0)
