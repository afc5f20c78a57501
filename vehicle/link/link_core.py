"""The link core of one vehicle: endpoints, parsing, signing, routing, sending, the stream
schedule and the pacing of replies.

What the core does not know is what the messages mean: each capability (vehicle/link/
stream_link.py, command_link.py, param_link.py, mission_link.py, ftp_link.py,
position_link.py) registers the message types it handles, the work it does every autopilot
tick and what it forgets at a reboot, as MAVSDK's plugins sit on its core. The core routes
every message that passed its checks to the one capability that registered its type.

Streams: the core sends every message of `set_schedule`'s schedule when it is due, framed by
the source given to `stream_from` (the telemetry) and only while an endpoint has someone to
hear it (a udpin peer, a TCP client, a udpout target); the messages due in one tick go out
in one write.

Parsing (vehicle/link/parsing.py): dropped and counted in `stats` are garbage bytes (bad
prefix), bad CRC, bad length, truncated frames, unknown message ids, messages for another
system, and (when signing is on) unsigned or badly signed packets. Counters also go out once a second as NAMED_VALUE_INT
once non-zero (names in STAT_NAMES).

Replies go back on the channel a request came from (`send(msg, channel)`); broadcasts
(`send(msg)`) go to every endpoint. Replies that ArduPilot spreads over the link's bandwidth
go through a paced outbox per peer (vehicle/link/paced_queue.py): `paced(ch)` /
`send_paced(msg, ch)`.

What one received chunk (a datagram may hold thousands of frames) makes the vehicle
broadcast is bounded: `broadcast_once` sends each key once after the chunk, at most
TEXTS_PER_CHUNK STATUSTEXT go out.

`on_data` returns True when the chunk held at least one packet that passed the checks (CRC,
length, known id and, with signing on, the signature): the UDP endpoint adds a peer only then.

An `intake` given to the core (the world's lockstep) sees every datagram of the UDP
endpoints before the core does, and hands on to `on_data` what it does not keep: datagrams
are whole packets, a TCP chunk is a piece of a stream.
"""
from __future__ import annotations

import math
import time
import traceback
from collections import Counter
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.signing import SIGNING_EPOCH, UNSIGNED, SignatureCheck
from vehicle.link.endpoints import Channel, Endpoint, make_endpoint, parse_endpoint
from vehicle.link.framing import Framer
from vehicle.link.outbox import DIRECT, Outbox
from vehicle.link.paced_queue import PacedQueue
from vehicle.link.parsing import ChunkParser, NullFile, rejected, split_frames

COMP_ID = mav.MAV_COMP_ID_AUTOPILOT1

# stats key -> NAMED_VALUE_INT name (10 characters at most)
STAT_NAMES = {"garbage": b"RX_GARBAGE", "bad_crc": b"RX_BADCRC", "bad_length": b"RX_BADLEN",
              "truncated": b"RX_TRUNC", "unknown_id": b"RX_UNKNOWN", "other_target": b"RX_OTHERTG",
              "bad_signature": b"RX_BADSIG", "unsigned": b"RX_UNSIGND"}

# the bandwidth ArduPilot's pacing assumes for a network link (bytes/s); 30 % of it goes to
# paced replies, at most 5 a tick (ArduPilot's limit without flow control)
LINK_BYTES_PER_S = 1_000_000.0
MAV2_OVERHEAD = 12            # header + CRC of a MAVLink 2 frame (+13 when signed)

MessageHandler = Callable[[object, Channel], None]          # (pymavlink message, reply channel)
# (the core, a datagram, its channel) -> what on_data would return
Intake = Callable[["LinkCore", bytes, Channel], bool]


def wire_size(msg, signed: bool = False) -> int:
    """Bytes `msg` takes on the wire as a MAVLink 2 frame (payload untrimmed: an upper bound)."""
    return type(msg).unpacker.size + MAV2_OVERHEAD + (13 if signed else 0)


def time_boot_ms(sim_s: float) -> int:
    """MAVLink's time_boot_ms of sim time `sim_s` (s since the world started): ms, wrapped to 32 bits."""
    return int(sim_s * 1000.0) & 0xFFFFFFFF


def statustext_message(severity: int, text: str):
    """STATUSTEXT of `text` (ASCII, cut to the 50 characters the field holds)."""
    return mav.MAVLink_statustext_message(severity, text.encode("ascii", "replace")[:50], 0, 0)


class LinkCore:
    TEXTS_PER_CHUNK = 30      # ArduPilot's STATUSTEXT queue: what does not fit is dropped

    def __init__(self, sysid: int, clock: Callable[[], float], endpoints: list[str],
                 signing_key: bytes | None = None, intake: Intake | None = None,
                 outbox: Outbox = DIRECT) -> None:
        self.sysid = sysid
        self.clock = clock                    # () -> sim seconds since world start
        self.specs = list(endpoints)
        # outbox: what holds the endpoints' writes while the world steps (vehicle/link/outbox.py)
        self.endpoints: list[Endpoint] = [make_endpoint(s, self._receiver(s, intake), outbox) for s in endpoints]
        self.mav = mav.MAVLink(NullFile(), srcSystem=sysid, srcComponent=COMP_ID)
        self.framer = Framer(self.mav)         # streams: packed without message objects
        self.stats: Counter = Counter()
        self.parser = ChunkParser(self.stats)
        self.signing_key = signing_key
        self.outboxes: dict[Channel, PacedQueue] = {}   # paced replies per peer
        self.handlers: dict[str, MessageHandler] = {"TIMESYNC": self._on_timesync}
        self._ticks: list[Callable[[], None]] = []
        # the streams: msgid -> interval (s), msgid -> next due (sim s), the earliest of those
        # (a lower bound; -inf: scan), and what frames them (stream_from)
        self.schedule: dict[int, float] = {}
        self.next_due: dict[int, float] = {}
        self.next_any = -math.inf
        self._stream_source = None
        self._reboot_hooks: list[Callable[[], None]] = []
        self._close_hooks: list[Callable[[], None]] = []
        if signing_key:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = 0
            self.mav.signing.timestamp = int((time.time() - SIGNING_EPOCH) * 1e5)
            self._sign_check = SignatureCheck(signing_key, clock=self.mav.signing)

    def _receiver(self, spec: str, intake: Intake | None):
        if intake is None or parse_endpoint(spec)[0] == "tcpin":
            return self.on_data
        return lambda data, channel: intake(self, data, channel)

    # ----- what capabilities plug in --------------------------------------------------------
    def register(self, msg_type: str, handler: MessageHandler) -> None:
        """`handler(msg, channel)` handles every checked message of `msg_type` for us (one
        capability per type)."""
        if msg_type in self.handlers:
            raise ValueError(f"{msg_type} is already handled by {self.handlers[msg_type]!r}")
        self.handlers[msg_type] = handler

    def on_tick(self, update: Callable[[], None]) -> None:
        """`update()` runs every autopilot tick after the streams, in registration order."""
        self._ticks.append(update)

    def stream_from(self, source) -> None:
        """`source.frame(msgid)` frames the streamed message `msgid` with this link's framer
        (None: nothing to send now); what is streamed when is `set_schedule`'s."""
        self._stream_source = source

    def set_schedule(self, schedule: dict[int, float]) -> None:
        """Stream these messages (msgid -> interval, sim s) from now on: a message already
        streamed keeps its next due time, a new one is due at once."""
        self.schedule = schedule
        now = self.clock()
        for i in list(self.next_due):
            if i not in schedule:
                del self.next_due[i]
        for i in schedule:
            self.next_due.setdefault(i, now)
        self.next_any = -math.inf          # recompute the earliest due time on the next update

    def on_reboot(self, forget: Callable[[], None]) -> None:
        """`forget()` runs when the vehicle reboots (after the autopilot restarted)."""
        self._reboot_hooks.append(forget)

    def on_close(self, hook: Callable[[], None]) -> None:
        """`hook()` runs when the link closes, before its endpoints do."""
        self._close_hooks.append(hook)

    # ----- life ------------------------------------------------------------------------------
    async def start(self) -> None:
        for ep in self.endpoints:
            await ep.start()

    def close(self) -> None:
        for hook in self._close_hooks:
            hook()
        for ep in self.endpoints:
            ep.close()

    def rebooted(self, sysid: int) -> None:
        """The vehicle rebooted with `sysid` (its SYSID_THISMAV): queued replies are dropped,
        every capability forgets what a new boot does not know. Peers stay."""
        self.sysid = self.mav.srcSystem = sysid
        for q in self.outboxes.values():
            q.clear()
        self.outboxes.clear()
        for forget in self._reboot_hooks:
            forget()
        self.stats["reboots"] += 1

    # ----- sending ---------------------------------------------------------------------------
    def send(self, msg, channel: Channel | None = None) -> None:
        """`msg` (a pymavlink message) to `channel`, or to every endpoint."""
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        self.stats["tx"] += 1
        if channel is not None:
            channel.send(buf)
        else:
            for ep in self.endpoints:
                ep.send(buf)

    def statustext(self, severity: int, text: str) -> None:
        """STATUSTEXT to every endpoint (at most TEXTS_PER_CHUNK per received chunk)."""
        if self._once is not None:           # inside a received chunk: bounded, see on_data
            self._texts += 1
            if self._texts > self.TEXTS_PER_CHUNK:
                self.stats["text_dropped"] += 1
                return
        self.send(statustext_message(severity, text))

    _texts = 0
    # broadcasts a received chunk causes, sent once each after it (key -> message builder):
    # a datagram packed with a thousand PARAM_SETs echoes each parameter once to every peer,
    # not a thousand times (ArduPilot's full send queue drops the excess the same way)
    _once: dict | None = None

    def broadcast_once(self, key, build: Callable[[], object]) -> None:
        """Send build() to every endpoint, once per received chunk for the same key."""
        if self._once is None:
            self.send(build())
        else:
            self._once[key] = build

    def take_signing(self) -> tuple[bytes, int, int] | None:
        """(key, link_id, timestamp) for a frame packed outside the link (the world's lockstep
        TICK), its timestamp taken from this link's signing stream, which moves on; None
        without signing."""
        if not self.signing_key:
            return None
        sig = self.mav.signing
        ts, sig.timestamp = sig.timestamp, sig.timestamp + 1
        return self.signing_key, sig.link_id, ts

    # ----- paced replies ---------------------------------------------------------------------
    def paced(self, ch: Channel) -> PacedQueue:
        """The paced outbox of the peer behind `ch` (created on first use)."""
        q = self.outboxes.get(ch)
        if q is None:
            q = self.outboxes[ch] = PacedQueue(LINK_BYTES_PER_S)
        return q

    def wire_size(self, msg) -> int:
        """Bytes `msg` takes on this link (signed or not)."""
        return wire_size(msg, bool(self.signing_key))

    def send_paced(self, msg, ch: Channel) -> bool:
        """Queue one reply for `ch`; False (counted as tx_dropped) when its outbox is full."""
        if self.paced(ch).push(msg, self.wire_size(msg)):
            return True
        self.stats["tx_dropped"] += 1
        return False

    # ----- every autopilot tick --------------------------------------------------------------
    def update(self, t: float) -> None:
        """At sim time t (the autopilot rate): the streamed messages due, every capability's
        tick, the paced replies due and, once a second, the receive counters. The streamed
        messages of one tick go out together: one UDP datagram (MAVLink allows several frames
        per datagram; ArduPilot's UDP output does the same), one TCP write."""
        if t + 1e-9 >= self.next_any:      # most ticks nothing is due: skip the scan (1,000 vehicles)
            self._stream(t)
        for tick in self._ticks:
            tick()
        if self.outboxes:
            self._drain_outboxes(t)
        if t >= self.next_stats:
            self.next_stats = t + 1.0
            stats = self.stats
            for k, name in STAT_NAMES.items():
                if stats[k]:
                    self.send(mav.MAVLink_named_value_int_message(time_boot_ms(self.clock()), name, int(stats[k])))

    next_stats = 0.0

    def _drain_outboxes(self, t: float) -> None:
        for ch, q in list(self.outboxes.items()):
            if ch.closed:
                del self.outboxes[ch]
                continue
            for msg in q.due(t):
                self.send(msg, ch)
            if q.idle():
                del self.outboxes[ch]

    def _stream(self, t: float) -> None:
        due = self.next_due
        batch = []
        first = math.inf
        # streams nobody can hear (no udpin peer, no TCP client yet) are not built: their
        # schedule runs on, the sequence number waits for a listener
        heard = any(ep.listened() for ep in self.endpoints)
        frame = self._stream_source.frame
        link_mav = self.mav
        for msgid, interval in self.schedule.items():
            nd = due[msgid]
            if t + 1e-9 >= nd:
                buf = frame(msgid) if heard else None
                if buf is not None:
                    batch.append(buf)
                    link_mav.seq = (link_mav.seq + 1) % 256
                nd += interval
                nd = due[msgid] = nd if nd > t else t + interval
            if nd < first:
                first = nd
        self.next_any = first
        if batch:
            self.stats["tx"] += len(batch)
            buf = b"".join(batch)
            for ep in self.endpoints:
                ep.send(buf)

    # ----- receiving -------------------------------------------------------------------------
    def on_data(self, data: bytes, channel: Channel, signed_checked: bool = False) -> bool:
        """Parse and handle one received chunk; True if a packet in it passed the checks.
        signed_checked: its signatures were judged on arrival (:meth:`drop_refused_now`)."""
        msgs = self.parser.parse(data, channel)
        ok = False
        self._once, self._texts = {}, 0
        try:
            for m in msgs:
                try:
                    ok = self._classify_and_handle(m, channel, signed_checked) or ok
                except Exception:  # a handler bug must not kill the vehicle: count it, say where
                    self.stats["handler_error"] += 1
                    traceback.print_exc()
        finally:
            once, self._once = self._once, None
            for build in once.values():
                self.send(build())
        return ok

    def _classify_and_handle(self, m, channel: Channel, signed_checked: bool = False) -> bool:
        """Count or route one parsed message; True if it passed the checks (a real peer)."""
        if rejected(m, self.stats):
            return False
        if self.signing_key and not signed_checked and not self.signature_ok(m.get_msgbuf(), m.get_srcSystem(), m.get_srcComponent()):
            return False
        self.stats["rx"] += 1
        if m.get_srcSystem() == self.sysid and m.get_srcComponent() == COMP_ID:
            return False             # our own echo (e.g. a router reflecting us)
        tgt = getattr(m, "target_system", None)
        if tgt is not None and tgt not in (0, self.sysid):
            self.stats["other_target"] += 1
            return True
        tc = getattr(m, "target_component", None)
        msg_type = m.get_type()
        if tc is not None and tc not in (0, COMP_ID) and msg_type != "HEARTBEAT":
            self.stats["other_target"] += 1
            return True
        handler = self.handlers.get(msg_type)
        if handler is not None:
            handler(m, channel)
        return True

    def drop_refused_now(self, data: bytes) -> bytes:
        """`data` without the frames whose signature this link refuses, judged now (and
        counted): for a datagram handled later (the world holds a lockstep participant's
        packets to a TICK boundary) while its sender's ACKs are judged on arrival. Judged
        later, a frame is older than the newest of its stream: a replay. Hand what is left to
        :meth:`on_data` with signed_checked."""
        frames, rest = split_frames(data)
        kept = [f for f, sysid, compid in frames if self.signature_ok(f, sysid, compid)]
        return b"".join(kept) + rest

    def signature_ok(self, buf: bytes, sysid: int, compid: int) -> bool:
        """MAVLink 2 signing (common.mavlink.signing) of one raw frame (also the world's
        TOWERLINK_LOCKSTEP, read before this link): unsigned, badly signed, replayed and stale
        frames are counted here and refused."""
        why = self._sign_check.check(buf, sysid, compid)
        if why is None:
            return True
        self.stats["unsigned" if why == UNSIGNED else "bad_signature"] += 1
        return False

    def _on_timesync(self, m, ch: Channel) -> None:
        # a request (tc1 0): answer tc1 = our sim clock in ns (never 0, which would read as a
        # request), ts1 echoed; the sender gets its round trip from ts1 on its own clock
        if m.tc1 == 0:
            self.send(mav.MAVLink_timesync_message(max(1, int(self.clock() * 1e9)), m.ts1), ch)
