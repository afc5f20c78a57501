"""MAVFTP sessions as ArduPilot's GCS_FTP keeps them (master's GCS_FTP class): a table of
AP_MAVLINK_FTP_MAX_SESSIONS (5) slots, each keyed by the requester's (sysid, compid, channel)
and the session byte the client chose, each holding at most one open file.

- A request whose key matches no slot takes the slot idle longest; if that one answered
  within FTP_SESSION_TIMEOUT (3 s) the request gets NoSessionsAvailable instead. The slot's
  file is closed first.
- A slot idle for FTP_SESSION_KILL_TIMEOUT (20 s) is closed.
- A slot is "active" from its last reply; the reply to TerminateSession makes it idle.
- ResetSessions closes every slot of that (sysid, compid, channel).

Times are seconds of the clock the server is given (the wall clock: the timeouts are the
clients' patience, not sim time).
"""
from __future__ import annotations

from collections.abc import Hashable

SLOTS = 5
TAKEOVER_S = 3.0            # FTP_SESSION_TIMEOUT
KILL_S = 20.0               # FTP_SESSION_KILL_TIMEOUT


class Session:
    def __init__(self) -> None:
        self.peer: Hashable | None = None
        self.session_id: int | None = None
        self.file = None                          # an open BytesFile / DiskFile / StagedFile
        self.last_send: float | None = None       # None: idle (ArduPilot's last_send_ms == 0)

    def close(self) -> None:
        """Close the open file (an upload is put in place); the slot becomes idle. Raises the
        OSError of a failed close, after which the file counts as closed all the same."""
        f, self.file = self.file, None
        self.last_send = None
        if f is not None:
            f.close()

    def close_quietly(self) -> None:
        try:
            self.close()
        except OSError:
            pass

    def idle_for(self, now: float) -> float:
        return float("inf") if self.last_send is None else now - self.last_send


class SessionTable:
    def __init__(self) -> None:
        self.slots = [Session() for _ in range(SLOTS)]

    def find(self, peer: Hashable, session_id: int, now: float) -> Session | None:
        """The slot for this key, claimed if new; None when every slot is busy."""
        for s in self.slots:
            if s.peer == peer and s.session_id == session_id:
                return s
        oldest = max(self.slots, key=lambda s: s.idle_for(now))
        if oldest.idle_for(now) < TAKEOVER_S:
            return None
        oldest.close_quietly()
        oldest.peer, oldest.session_id = peer, session_id
        return oldest

    def reset(self, peer: Hashable) -> None:
        for s in self.slots:
            if s.peer == peer:
                s.close_quietly()

    def expire(self, now: float) -> None:
        for s in self.slots:
            if s.last_send is not None and now - s.last_send > KILL_S:
                s.close_quietly()

    def close_all(self) -> None:
        for s in self.slots:
            s.close_quietly()
