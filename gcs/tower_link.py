"""One tower link shared by every drone's mission thread.

A family's tower used to open one connection per drone. The bridge's tower link sends the
whole system's telemetry to every peer, so N connections decoded N times everything (N**2
work) and past 64 peers the link's peer table (common.mavlink.peers) dropped some. A GCS flying many
drones holds one link: :class:`SharedClient` is a gcs.client.Client whose socket only one
thread, the pump, reads; each drone's gcs.tower_mission.Mission runs in its own thread on the same
object, and its blocking helpers (set_mode, arm, takeoff, wait_reached, ...) park in
``poll`` until the pump has handled the next batch of messages.

Lockstep with a family: the pump is the tower's one participant. After a TICK
it wakes every mission thread and ACKs the TICK only once each registered thread has acted
on it and parked again (a barrier), so what the family decides depends on sim time alone.
A thread that waits on something else than the link (a gate) waits with the link's
``wait_until``, which parks in ``poll`` too.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from gcs.client import Client, ClientTimeout

PUMP_POLL = 0.02            # wall s per pump pass without lockstep
RCVBUF = 1 << 23             # bytes asked for the link's receive buffer
BARRIER_TIMEOUT = 10.0      # wall s the pump waits for a mission thread before going on


class SharedClient(Client):
    """A Client read by one pump thread and used by many mission threads at once."""

    def __init__(self, master: Any, **kw: Any) -> None:
        self._cond = threading.Condition()
        self._send_lock = threading.RLock()          # before Client.__init__: it sends a heartbeat
        self._pump: threading.Thread | None = None
        super().__init__(master, **kw)
        sock = getattr(master, "port", None)         # pymavlink's UDP socket
        if hasattr(sock, "setsockopt"):
            # 100 drones' telemetry arrives in bursts at each world step: room for a second of
            # it, so a busy moment does not drop datagrams (the kernel caps it at rmem_max)
            import socket
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RCVBUF)
            except OSError:
                pass
        self._gen = 0                                # pump passes handled
        self._parked: dict[int, int] = {}            # thread id -> the pass it has acted on
        self._members: set[int] = set()              # threads the lockstep barrier waits for
        self._stop = threading.Event()
        self.pump_error: BaseException | None = None

    # -- the pump

    def start(self) -> SharedClient:
        """Start the pump thread (the only reader of the socket)."""
        self._pump = threading.Thread(target=self._run_pump, name="tower-link", daemon=True)
        self._pump.start()
        return self

    def _run_pump(self) -> None:
        try:
            while not self._stop.is_set():
                if self.lockstep:
                    self._barrier()
                    Client.poll(self)               # ACK the last TICK, read until the next
                else:
                    Client.poll(self, PUMP_POLL)
                with self._cond:
                    self._gen += 1
                    self._cond.notify_all()
        except BaseException as exc:  # noqa: BLE001 - told to every waiting thread
            self.pump_error = exc
            with self._cond:
                self._gen += 1
                self._cond.notify_all()

    def _barrier(self) -> None:
        """Wait until every member thread has acted on the current pass and parked again."""
        end = time.monotonic() + BARRIER_TIMEOUT
        with self._cond:
            while not self._stop.is_set():
                late = [t for t in self._members if self._parked.get(t) != self._gen]
                if not late:
                    return
                left = end - time.monotonic()
                if left <= 0:
                    names = {t.ident: t.name for t in threading.enumerate()}
                    busy = ", ".join(names.get(t, str(t)) for t in late[:5])
                    self.log(f"tower link: {len(late)} mission thread(s) ({busy}) busy for "
                             f"{BARRIER_TIMEOUT:g} s wall with a TICK not acted on; going on")
                    return
                self._cond.wait(min(left, 1.0))

    # -- mission threads

    def member(self) -> None:
        """The calling thread takes part in the lockstep barrier (until :meth:`leave`)."""
        with self._cond:
            self._members.add(threading.get_ident())

    def leave(self) -> None:
        with self._cond:
            self._members.discard(threading.get_ident())
            self._parked.pop(threading.get_ident(), None)
            self._cond.notify_all()

    def poll(self, timeout: float = 0.0) -> int:
        """Wait for the pump's next pass (with lockstep: the next TICK, whatever `timeout`)."""
        if self._pump is None or threading.current_thread() is self._pump:
            return Client.poll(self, timeout)
        me = threading.get_ident()
        end = time.monotonic() + (self.lockstep_timeout if self.lockstep else max(0.0, timeout))
        with self._cond:
            seen = self._gen
            self._parked[me] = seen
            self._cond.notify_all()                  # the pump may be waiting for us
            while self._gen == seen:
                left = end - time.monotonic()
                if left <= 0:
                    if self.lockstep:
                        raise ClientTimeout(f"lockstep: no TICK from the world in {self.lockstep_timeout:g} s")
                    return 0
                self._cond.wait(left)
        if self.pump_error is not None:
            raise ClientTimeout(f"the tower link stopped: {self.pump_error}")
        return 1

    def send(self, fn: Callable[[], None]) -> None:
        with self._send_lock:                        # one MAVLink sequence, one datagram at a time
            super().send(fn)

    def _send_heartbeat(self) -> None:
        with self._send_lock:
            super()._send_heartbeat()

    def close(self) -> None:
        self._stop.set()
        with self._cond:
            self._cond.notify_all()
        if self._pump is not None and self._pump is not threading.current_thread():
            self._pump.join(self.lockstep_timeout + 1.0)
        with self._send_lock:
            super().close()
