"""A client's link core: one pymavlink connection read and written as a GCS.

It sends a heartbeat every second, reads messages into a :class:`~gcs.client.state.SystemTracker`
and hands them to subscribers, signs and checks packets with a key (gcs.client.link_signing),
records a tlog, and with lockstep takes part in the world's TICK/ACK handshake. Every wait
runs on :meth:`Link.clock`: wall seconds, or with lockstep the sim time of the newest TICK.
The capability plugins (gcs.client.action, .telemetry, .goals, ...) are built on it.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Self

from common.mavlink import lockstep as ls
from common.mavlink.ids import TOWER_SYSID
from gcs.client.connection import open_connection, open_dialect_connection
from gcs.client.errors import ClientError, ClientTimeout
from gcs.client.lazy_rx import LazyReceiver
from gcs.client.link_signing import LinkSigning, SigningViews
from gcs.client.lockstep import JOIN_PERIOD, LOCKSTEP_TIMEOUT, TickClock
from gcs.client.mav import mavlink
from gcs.client.state import SystemState, SystemTracker
from gcs.client.tlog import Tlog

# The signing link id a Client sends on by default: 0 is the vehicles' own (and the bridge's
# own messages'), 1 the bridge's re-packing of others' messages (a tower goal it translated goes
# to the vehicle as (link 1, TOWER_SYSID, 190)); a third stream never looks like a replay of either.
# Not 0 also because pymavlink's mavutil adopts the link id of a signed packet from its target
# vehicle while its own is 0 (then the tower would share the bridge's link 1).
SIGNING_LINK_ID = 2


class Link(SigningViews):
    """One MAVLink link with state tracking, heartbeats and deadline-bounded waiting (its signing
    facts: gcs.client.link_signing.SigningViews)."""

    def __init__(self, master: Any, *, log: Callable[[str], None] | None = None,
                 heartbeat_interval: float = 1.0, tlog: str | None = None,
                 lockstep: bool = False, lockstep_timeout: float = LOCKSTEP_TIMEOUT,
                 lockstep_target: int = 0, signing_key: bytes | None = None,
                 link_id: int = SIGNING_LINK_ID) -> None:
        self.master = master
        self.mav = master.mav
        # 0: a participant for every vehicle (through the bridge); a sysid: for that vehicle
        # alone, on its own endpoint (the van's driver)
        self.lockstep_target = lockstep_target
        self.lockstep = lockstep                   # the world's TICKs are this client's clock
        self.lockstep_timeout = lockstep_timeout   # wall s without a TICK: ClientTimeout
        self.ticks = TickClock()
        self._closed = False
        self._last_join = -1e9
        self._last_tick_wall = -1e9
        # before the first packet this client sends
        self.signing = LinkSigning(self.mav, bytes(signing_key), link_id) if signing_key else None
        self.tracker = SystemTracker(self._stamp)
        self.systems: dict[int, SystemState] = self.tracker.systems
        self.log = log or (lambda s: None)
        self.heartbeat_interval = heartbeat_interval
        self._last_hb_sent = 0.0
        self._listeners: tuple[Callable[[Any], None], ...] = ()
        self._subscribers: dict[str, tuple[Callable[[Any], None], ...]] = {}
        self._tlog = Tlog(tlog) if tlog else None
        if self._tlog is not None:
            self.mav.set_send_callback(self._tlog.on_sent)
        self.bad_packets = 0
        # telemetry cut into frames and decoded only where read (pymavlink's parser when signed)
        self._rx = LazyReceiver(master, self._tlog) if LazyReceiver.serves(master, self.signing is not None) \
            else None
        self.received = 0
        if lockstep:
            self.subscribe("TOWERLINK_LOCKSTEP", self._on_lockstep)
        self._send_heartbeat()
        if lockstep:
            self._join()

    @classmethod
    def connect(cls, conn: str = "udpout:127.0.0.1:14600", *, source_system: int = TOWER_SYSID,
                source_component: int = mavlink.MAV_COMP_ID_MISSIONPLANNER,
                log: Callable[[str], None] | None = None, tlog: str | None = None,
                factory: Callable[..., Any] | None = None, lockstep: bool = False,
                lockstep_target: int = 0, signing_key: bytes | None = None,
                link_id: int = SIGNING_LINK_ID) -> Self:
        """Open `conn` (pymavlink spelling: udpout:H:P, udpin:H:P, tcp:H:P) as a GCS.

        lockstep: join the world's lockstep through the bridge (TOWERLINK_LOCKSTEP, so the
        connection speaks the towerlink dialect); lockstep_target: the sysid of the one vehicle
        this client drives on that vehicle's own endpoint (0: every vehicle, through the bridge).
        Several lockstep clients of one program need a source_component each (the world tells
        participants apart by sysid and compid).

        signing_key: 32 bytes (common.mavlink.signing.key_from_text makes them from a passphrase or 64
        hex digits): sign everything sent, accept only packets signed with it (see gcs.client's
        docstring). link_id: the signing link id (0..255) of what this client sends (default
        SIGNING_LINK_ID, 2); through a signing bridge not 1, the link the bridge re-packs
        translated goals on as their sender (one stream from two senders looks like replays)."""
        if factory is None:
            factory = open_dialect_connection if lockstep else open_connection
        try:
            master = factory(conn, source_system, source_component)
        except OSError as exc:
            raise ClientError(f"cannot open {conn}: {exc}") from exc
        try:
            return cls(master, log=log, tlog=tlog, lockstep=lockstep, lockstep_target=lockstep_target,
                       signing_key=signing_key, link_id=link_id)
        except ClientError:
            master.close()
            raise

    # -- the clock

    def clock(self) -> float:
        """The clock every deadline, retry and resend of this client runs on (s): wall seconds,
        or with lockstep the sim time of the newest TICK (then a poll returns only at a TICK,
        so what the program decides depends on sim time alone, never on the machine's speed)."""
        if self.lockstep:
            return self.ticks.now()
        return time.monotonic()

    def _stamp(self) -> float:
        """When a received message is noted: with lockstep, just after the newest TICK (it
        arrived after the program acted on that TICK), so `stamp > t0` means "after the call"."""
        return self.clock() + (1e-6 if self.lockstep else 0.0)

    @property
    def tick_usec(self) -> int | None:
        """The newest TICK handled (sim us); None before the first or without lockstep."""
        return self.ticks.tick_usec

    # -- life

    def close(self) -> None:
        """Close the link (with lockstep after a LEAVE); a second call does nothing."""
        if self._closed:
            return
        self._closed = True
        if self.lockstep:
            self._lockstep_send(ls.LEAVE, self.ticks.tick_usec or 0)
        try:
            self.master.close()
        finally:
            if self._tlog is not None:
                self._tlog.close()
                self._tlog = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- receiving

    def add_listener(self, fn: Callable[[Any], None]) -> None:
        """Call fn(msg) for every message received (after the state is updated)."""
        self._listeners = (*self._listeners, fn)

    def subscribe(self, mtype: str, fn: Callable[[Any], None]) -> None:
        """Call fn(msg) for every received message of type `mtype` (after the state is updated)."""
        self._subscribers[mtype] = (*self._subscribers.get(mtype, ()), fn)

    def unsubscribe(self, mtype: str, fn: Callable[[Any], None]) -> None:
        left = tuple(f for f in self._subscribers.get(mtype, ()) if f is not fn)
        self._subscribers[mtype] = left

    def system(self, sysid: int) -> SystemState:
        """What this link heard from `sysid` (an empty state until it is heard)."""
        return self.tracker.system(sysid)

    def poll(self, timeout: float = 0.0) -> int:
        """Receive and process messages for up to `timeout` wall seconds; returns how many.

        With lockstep: first ACK the TICK handled last (everything the program did since has
        been sent), then receive until the next TICK, whatever `timeout` says; raises
        ClientTimeout when no TICK comes for `lockstep_timeout` wall seconds."""
        if self.lockstep:
            return self._poll_tick()
        end = time.monotonic() + max(0.0, timeout)
        n = 0
        while True:
            self._maybe_heartbeat()
            remaining = end - time.monotonic()
            try:
                got = self._receive(min(max(remaining, 0.0), self.heartbeat_interval))
            except (OSError, ValueError):  # transient socket trouble: keep the deadline
                got = False
                time.sleep(min(0.05, max(remaining, 0.0)))
            if got:
                n += 1
                continue
            if time.monotonic() >= end:
                return n

    def wait_until(self, cond: Callable[[], Any], timeout: float) -> Any:
        """Poll until cond() is truthy (returned) or `timeout` s of :meth:`clock` pass (None)."""
        end = self.clock() + timeout
        while True:
            v = cond()
            if v:
                return v
            left = end - self.clock()
            if left <= 0:
                return None
            self.poll(min(left, 0.05))

    def _receive(self, timeout: float) -> bool:
        """Handle the next message, waiting at most `timeout` wall s; False when none came."""
        rx = self._rx
        if rx is None:
            msg = self.master.recv_match(blocking=timeout > 0, timeout=timeout)
            if msg is not None:
                self._handle(msg)
            return msg is not None
        pkt = rx.next(timeout)          # recorded in the tlog; what is no packet counted
        self.bad_packets += rx.take_bad()
        if pkt is None:
            return False
        mtype = rx.name(pkt)
        self.received += 1
        if mtype in SystemTracker.READS or self._subscribers.get(mtype) or self._listeners:
            self._dispatch(rx.decode(pkt), mtype)
        elif said := self.tracker.note_time(pkt.sysid, rx.time_boot_ms(pkt)):   # read by no one
            self.log(said)
        return True

    def _handle(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self.bad_packets += 1
            if self.signing is not None:
                self.signing.on_bad_data(msg)
            return
        self.received += 1
        if self.signing is not None:
            self.signing.keep_link_id()
        if self._tlog is not None:
            self._tlog.write(msg)
        self._dispatch(msg, mtype)

    def _dispatch(self, msg: Any | None, mtype: str) -> None:
        """A message received and recorded: the tracker, then its subscribers and the listeners
        (None: it did not decode, counted by the receiver)."""
        if msg is None:
            return
        said = self.tracker.note(msg, mtype)
        if said:
            self.log(said)
        for fn in self._subscribers.get(mtype, ()):
            fn(msg)
        for fn in self._listeners:
            fn(msg)

    # -- sending

    def send(self, fn: Callable[[], None]) -> None:
        """Run fn() (one pymavlink *_send call); a failed send is logged, like a lost packet."""
        try:
            fn()
        except OSError as exc:  # e.g. ECONNREFUSED while the bridge restarts
            self.log(f"send failed ({exc}); will retry")

    def _maybe_heartbeat(self) -> None:
        # with lockstep a sim-time second: the vehicle's GCS failsafe (FS_GCS_*) counts sim time.
        # (clock() inlined: this runs for every message received)
        now = self.ticks.now() if self.lockstep else time.monotonic()
        if now - self._last_hb_sent >= self.heartbeat_interval:
            self._send_heartbeat()

    def _send_heartbeat(self) -> None:
        self._last_hb_sent = self.clock()
        try:
            self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                    mavlink.MAV_STATE_ACTIVE)
        except OSError:
            pass  # peer not there yet (connection refused on loopback): try again next second

    # -- lockstep (common.mavlink.lockstep's handshake; gcs.client.lockstep keeps the books)

    def _lockstep_send(self, kind: int, t_usec: int) -> None:
        send = getattr(self.mav, "towerlink_lockstep_send", None)
        if send is not None:
            who = ls.TOWER if not self.lockstep_target else ls.OTHER
            self.send(lambda: send(t_usec, self.lockstep_target, kind, who, 0))

    def _join(self) -> None:
        self._last_join = time.monotonic()
        self._lockstep_send(ls.JOIN, 0)

    def _on_lockstep(self, msg: Any) -> None:
        if msg.kind == ls.TICK:
            again = self.ticks.on_tick(msg.time_usec)
            if again is not None:
                self._lockstep_send(ls.ACK, again)

    def _send_due_ack(self) -> None:
        """ACK the TICK handled last: the program has acted on it (what a poll does first)."""
        due = self.ticks.take_ack()
        if due is not None:
            self._lockstep_send(ls.ACK, due)

    def _poll_tick(self) -> int:
        # the heartbeat is due on the TICKs' clock, which stands still until the next TICK ends
        # this poll: one look here, before the ACK (it belongs to this TICK), serves the whole poll
        self._maybe_heartbeat()
        self._send_due_ack()
        end = time.monotonic() + self.lockstep_timeout
        n = 0
        while True:
            # JOIN until the first TICK, and again after a second without one (a restarted
            # bridge does not know us; the world may have dropped us)
            wall = time.monotonic()
            if wall - self._last_join >= (JOIN_PERIOD if self.ticks.tick_usec is None else 1.0) and \
                    wall - self._last_tick_wall >= 1.0:
                self._join()
            try:
                got = self._receive(0.1)
            except (OSError, ValueError):
                got = False
                time.sleep(0.01)
            if got:
                n += 1
                if self.ticks.ack_due is not None:
                    self._last_tick_wall = time.monotonic()
                    return n
                continue
            if time.monotonic() >= end:
                raise ClientTimeout(f"lockstep: no TICK from the world in {self.lockstep_timeout:g} s")
