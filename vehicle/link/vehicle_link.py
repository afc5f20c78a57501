"""One vehicle's MAVLink side: parse what arrives on its endpoints, answer, stream telemetry.

Parsing: pymavlink's MAVLink 2 parser in robust mode, one parser per TCP client, and a
fresh parse of every UDP datagram (a datagram that ends inside a frame counts as truncated).
Dropped and counted in `stats`: garbage bytes (bad prefix), bad CRC, bad length, truncated
frames, unknown message ids, messages for another system, and (when signing is on) unsigned
or badly signed packets. Counters also go out once a second as NAMED_VALUE_INT
once non-zero (names in STAT_NAMES).

Streams are framed without message objects (vehicle/link/framing.py, byte for byte what
pymavlink packs) and only while an endpoint has someone to hear them (a udpin peer, a TCP
client, a udpout target); replies and STATUSTEXT are pymavlink messages packed by pymavlink.

Every COMMAND_LONG / COMMAND_INT for us gets exactly one COMMAND_ACK on the channel it came
from; replies (PARAM_VALUE for reads/lists, TIMESYNC, requested messages) go back there too;
streams, STATUSTEXT and PARAM_VALUE after a PARAM_SET go to every endpoint.

Parameter replies are paced as ArduPilot paces them (vehicle/link/paced_queue.py): one
outbox per peer, a PARAM_REQUEST_LIST restarts that peer's list instead of queueing another,
PARAM_REQUEST_READ replies wait in a bounded queue. `paced(ch)` / `send_paced(msg, ch)` are
the API for other reply kinds (the mission protocol).

What one received chunk (a datagram may hold thousands of frames) makes the vehicle
broadcast is bounded: each parameter's PARAM_VALUE echo once, at most TEXTS_PER_CHUNK
STATUSTEXT; parameters are written to the saved file once a tick.

`on_data` returns True when the chunk held at least one packet that passed the checks (CRC,
length, known id and, with signing on, the signature): the UDP endpoint adds a peer only then.
"""
from __future__ import annotations

import math
import traceback
import time
from collections import Counter

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.mavstr import mav_str
from common.mavlink.signing import SIGNING_EPOCH, UNSIGNED, SignatureCheck
from vehicle.files.root_dir import RootDir
from vehicle.link import ftp
from vehicle.link.endpoints import Channel, Endpoint, make_endpoint
from vehicle.link.framing import Framer
from vehicle.link.log_link import LOG_MESSAGES, LogLink
from vehicle.link.mission_link import MISSION_MESSAGES, MissionLink
from vehicle.link.paced_queue import PacedQueue
from vehicle.link.telemetry import DATA_STREAMS, Telemetry
from vehicle.logs.world_logs import WorldLogs
from vehicle.telemetry import version
from vehicle.vehicle_root import logs_dir

COMP_ID = mav.MAV_COMP_ID_AUTOPILOT1

LINK_COMMANDS = {mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAV_CMD_GET_MESSAGE_INTERVAL,
                 mav.MAV_CMD_REQUEST_MESSAGE, mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
                 mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, mav.MAV_CMD_DO_SEND_BANNER}
MAX_INTERVAL_US = 2**31 - 1   # MESSAGE_INTERVAL.interval_us is an int32


# stats key -> NAMED_VALUE_INT name (10 characters at most)
STAT_NAMES = {"garbage": b"RX_GARBAGE", "bad_crc": b"RX_BADCRC", "bad_length": b"RX_BADLEN",
              "truncated": b"RX_TRUNC", "unknown_id": b"RX_UNKNOWN", "other_target": b"RX_OTHERTG",
              "bad_signature": b"RX_BADSIG", "unsigned": b"RX_UNSIGND"}


# the bandwidth ArduPilot's pacing assumes for a network link (bytes/s); 30 % of it goes to
# parameter replies, at most 5 a tick (ArduPilot's limit without flow control)
LINK_BYTES_PER_S = 1_000_000.0
MAV2_OVERHEAD = 12            # header + CRC of a MAVLink 2 frame (+13 when signed)


def wire_size(msg, signed: bool = False) -> int:
    """Bytes `msg` takes on the wire as a MAVLink 2 frame (payload untrimmed: an upper bound)."""
    return type(msg).unpacker.size + MAV2_OVERHEAD + (13 if signed else 0)


class _Out:
    """pymavlink encoder needs a file; we pack ourselves, so nothing is written."""
    def write(self, b):
        pass


def _param_id(s) -> str:
    return mav_str(s).strip().upper()


class VehicleLink:
    def __init__(self, ap, clock, unix_start_us: int, endpoints: list[str],
                 signing_key: bytes | None = None, params_changed=None, files_root=None,
                 logs: WorldLogs | None = None) -> None:
        """files_root: the vehicle's directory MAVFTP serves (vehicle/vehicle_root.py), None
        for a temporary one removed at close(); logs: the world's onboard logs (this
        vehicle's go to files_root's logs/), None: no onboard log, LOG_* requests unanswered."""
        self.ap = ap
        self.files_root = RootDir(files_root)
        self.clock = clock                    # () -> sim seconds since world start
        self.unix_start_us = unix_start_us
        self.specs = list(endpoints)
        self.endpoints: list[Endpoint] = [make_endpoint(s, self.on_data) for s in endpoints]
        self.mav = mav.MAVLink(_Out(), srcSystem=ap.sysid, srcComponent=COMP_ID)
        self.framer = Framer(self.mav)         # streams: packed without message objects
        self.udp_parser = self._parser()
        self.telemetry = Telemetry(self)
        self.stats: Counter = Counter()
        self.params_changed = params_changed or (lambda names: None)
        self.intervals: dict[int, float] = {}     # msgid -> seconds; <0 disabled (SET_MESSAGE_INTERVAL)
        self.next_due: dict[int, float] = {}
        self.schedule: dict[int, float] = {}
        self.signing_key = signing_key
        self.outboxes: dict[Channel, PacedQueue] = {}   # paced replies per peer
        if signing_key:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = 0
            self.mav.signing.timestamp = int((time.time() - SIGNING_EPOCH) * 1e5)
            self._sign_check = SignatureCheck(signing_key, clock=self.mav.signing)
        self.missions = MissionLink(self)      # mission / fence / rally protocol
        self.logs = (LogLink(self, ap, logs, lambda: logs_dir(self.files_root.path()), unix_start_us)
                     if logs is not None else None)
        self._rebuild_schedule()
        ap.outbox.subscribe(text=self.statustext)
        ap.params.deferred = True              # saved once a tick by update(), and at close()

    def _parser(self):
        p = mav.MAVLink(_Out(), srcSystem=0, srcComponent=0)
        p.robust_parsing = True
        return p

    async def start(self) -> None:
        for ep in self.endpoints:
            await ep.start()

    def close(self) -> None:
        self.ap.params.flush()
        if self.logs is not None:
            self.logs.closed()
        if self._ftp is not None:
            self._ftp.close()                  # uploads in progress are put in place
        self.files_root.close()
        for ep in self.endpoints:
            ep.close()

    # ----- sending ----------------------------------------------------------------------
    def send(self, msg, channel: Channel | None = None) -> None:
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        self.stats["tx"] += 1
        if channel is not None:
            channel.send(buf)
        else:
            for ep in self.endpoints:
                ep.send(buf)

    TEXTS_PER_CHUNK = 30      # ArduPilot's STATUSTEXT queue: what does not fit is dropped

    def statustext(self, severity: int, text: str) -> None:
        if self._once is not None:           # inside a received chunk: bounded, see on_data
            self._texts += 1
            if self._texts > self.TEXTS_PER_CHUNK:
                self.stats["text_dropped"] += 1
                return
        self.send(self._statustext_msg(severity, text))

    _texts = 0

    @staticmethod
    def _statustext_msg(severity: int, text: str):
        return mav.MAVLink_statustext_message(severity, text.encode("ascii", "replace")[:50], 0, 0)

    # ----- streams ----------------------------------------------------------------------
    def _rebuild_schedule(self) -> None:
        sched: dict[int, float] = {mav.MAVLINK_MSG_ID_HEARTBEAT: 1.0}
        for group, ids in self.telemetry.groups.items():
            hz = float(self.ap.params.get(group, 0) or 0)
            if hz > 0:
                for i in ids:
                    sched[i] = min(sched.get(i, math.inf), 1.0 / hz)
        for i, iv in self.intervals.items():
            if iv < 0:
                sched.pop(i, None)
            else:
                sched[i] = iv
        self.schedule = sched
        now = self.clock()
        for i in list(self.next_due):
            if i not in sched:
                del self.next_due[i]
        for i in sched:
            self.next_due.setdefault(i, now)
        self.next_any = -math.inf          # recompute the earliest due time on the next update

    def update(self, t: float) -> None:
        """Send whatever is due at sim time t (called at the autopilot rate). The messages of
        one tick go out together: one UDP datagram (MAVLink allows several frames per
        datagram; ArduPilot's UDP output does the same), one TCP write."""
        due = self.next_due
        batch = []
        if t + 1e-9 >= self.next_any:      # most ticks nothing is due: skip the scan (1,000 vehicles)
            first = math.inf
            # streams nobody can hear (no udpin peer, no TCP client yet) are not built: their
            # schedule runs on, the sequence number waits for a listener
            heard = any(ep.listened() for ep in self.endpoints)
            for msgid, interval in self.schedule.items():
                nd = due[msgid]
                if t + 1e-9 >= nd:
                    buf = self.telemetry.frame(msgid) if heard else None
                    if buf is not None:
                        batch.append(buf)
                        self.mav.seq = (self.mav.seq + 1) % 256
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
        self.missions.update(t)
        if self.logs is not None:
            self.logs.tick()
        origin = self.ap.ekf_origin()
        if origin != self._origin_sent:          # set (first good estimate) or moved
            self._origin_sent = origin
            msg = self.telemetry.gps_global_origin()
            if msg is not None:
                self.send(msg)
        if self.outboxes:
            self._drain_outboxes(t)
        self.ap.params.flush()         # PARAM_SETs of this tick reach the saved file together
        if t >= self.next_stats:
            self.next_stats = t + 1.0
            for k, name in STAT_NAMES.items():
                if self.stats[k]:
                    self.send(mav.MAVLink_named_value_int_message(self.telemetry.boot_ms(), name,
                                                                  int(self.stats[k])))

    next_stats = 0.0
    next_any = -math.inf                   # earliest next_due (a lower bound; -inf: scan)
    _origin_sent: tuple | None = None

    # ----- paced replies ------------------------------------------------------------------
    def paced(self, ch: Channel) -> PacedQueue:
        """The paced outbox of the peer behind `ch` (created on first use)."""
        q = self.outboxes.get(ch)
        if q is None:
            q = self.outboxes[ch] = PacedQueue(LINK_BYTES_PER_S)
        return q

    def send_paced(self, msg, ch: Channel) -> bool:
        """Queue one reply for `ch`; False (counted as tx_dropped) when its outbox is full."""
        if self.paced(ch).push(msg, wire_size(msg, bool(self.signing_key))):
            return True
        self.stats["tx_dropped"] += 1
        return False

    def _drain_outboxes(self, t: float) -> None:
        for ch, q in list(self.outboxes.items()):
            if ch.closed:
                del self.outboxes[ch]
                continue
            for msg in q.due(t):
                self.send(msg, ch)
            if q.idle():
                del self.outboxes[ch]

    # ----- receiving --------------------------------------------------------------------
    def on_data(self, data: bytes, channel: Channel) -> bool:
        """Parse and handle one received chunk; True if a packet in it passed the checks."""
        if channel.stream:
            if channel.parser is None:
                channel.parser = self._parser()
            parser = channel.parser
        else:
            parser = self.udp_parser
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:            # never let a malformed input escape
            msgs = []
            self.stats["garbage"] += 1
            parser.buf = bytearray()
            parser.buf_index = 0
        if not channel.stream and parser.buf_len() > 0:
            self.stats["truncated"] += 1
            parser.buf = bytearray()
            parser.buf_index = 0
            parser.expected_length = mav.HEADER_LEN_V1 + 2
        ok = False
        self._once, self._texts = {}, 0
        try:
            for m in msgs:
                try:
                    ok = self._classify_and_handle(m, channel) or ok
                except Exception:  # a handler bug must not kill the vehicle: count it, say where
                    self.stats["handler_error"] += 1
                    traceback.print_exc()
        finally:
            once, self._once = self._once, None
            for build in once.values():
                self.send(build())
        return ok

    # broadcasts a received chunk causes, sent once each after it (key -> message builder):
    # a datagram packed with a thousand PARAM_SETs echoes each parameter once to every peer,
    # not a thousand times (ArduPilot's full send queue drops the excess the same way)
    _once: dict | None = None

    def broadcast_once(self, key, build) -> None:
        """Send build() to every endpoint, once per received chunk for the same key."""
        if self._once is None:
            self.send(build())
        else:
            self._once[key] = build

    def _classify_and_handle(self, m, channel: Channel) -> bool:
        """Count or handle one parsed message; True if it passed the checks (a real peer)."""
        if isinstance(m, mav.MAVLink_bad_data):
            reason = str(getattr(m, "reason", ""))
            if "CRC" in reason:
                self.stats["bad_crc"] += 1
            elif "prefix" in reason:
                self.stats["garbage"] += 1
            elif "length" in reason or "Bad message" in reason:
                self.stats["bad_length"] += 1
            else:
                self.stats["bad_data"] += 1
            return False
        if isinstance(m, mav.MAVLink_unknown):
            self.stats["unknown_id"] += 1
            return False
        if self.signing_key and not self._signature_ok(m):
            return False
        self.stats["rx"] += 1
        sysid = m.get_srcSystem()
        if sysid == self.ap.sysid and m.get_srcComponent() == COMP_ID:
            return False             # our own echo (e.g. a router reflecting us)
        tgt = getattr(m, "target_system", None)
        if tgt is not None and tgt not in (0, self.ap.sysid):
            self.stats["other_target"] += 1
            return True
        tc = getattr(m, "target_component", None)
        if tc is not None and tc not in (0, COMP_ID) and m.get_type() not in ("HEARTBEAT",):
            self.stats["other_target"] += 1
            return True
        handler = getattr(self, "on_" + m.get_type(), None)
        if handler is not None:
            handler(m, channel)
        elif m.get_type() in MISSION_MESSAGES or m.get_type() == "MISSION_SET_CURRENT":
            self.missions.handle(m, channel)
        elif m.get_type() in LOG_MESSAGES and self.logs is not None:
            self.logs.handle(m, channel)
        return True

    def _signature_ok(self, m) -> bool:
        """MAVLink 2 signing (common.mavlink.signing): unsigned, badly signed, replayed and stale
        packets are counted and dropped."""
        return self.signature_ok(m.get_msgbuf(), m.get_srcSystem(), m.get_srcComponent())

    def signature_ok(self, buf: bytes, sysid: int, compid: int) -> bool:
        """The check on one raw frame (also the world's TOWERLINK_LOCKSTEP, read before this
        link): unsigned or badly signed frames are counted here and refused."""
        why = self._sign_check.check(buf, sysid, compid)
        if why is None:
            return True
        self.stats["unsigned" if why == UNSIGNED else "bad_signature"] += 1
        return False

    # ----- handlers ----------------------------------------------------------------------
    def on_HEARTBEAT(self, m, ch) -> None:
        if m.type == mav.MAV_TYPE_GCS:
            self.ap.gcs_heartbeat()

    def ack(self, ch, command: int, result: int, m) -> None:
        self.send(mav.MAVLink_command_ack_message(command, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()), ch)

    def on_COMMAND_LONG(self, m, ch) -> None:
        p = [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]
        self._run_command(m, ch, p, None, None, None)

    def on_COMMAND_INT(self, m, ch) -> None:
        p = [m.param1, m.param2, m.param3, m.param4, float(m.x), float(m.y), m.z]
        self._run_command(m, ch, p, m.frame, m.x, m.y)

    _after_ack: list = []
    _reboot_after_ack = False

    def _run_command(self, m, ch, p, frame, x, y) -> None:
        self._after_ack = []
        self._reboot_after_ack = False
        try:
            result = self._command(m.command, p, ch, m, frame, x, y)
        except Exception:       # a handler bug: still exactly one ACK, and say where
            self.stats["handler_error"] += 1
            traceback.print_exc()
            result, self._after_ack = mav.MAV_RESULT_FAILED, []
        self.ack(ch, m.command, result, m)
        # like ArduPilot: the ACK first, then the message a command asked for (or the reboot)
        msgs, self._after_ack = self._after_ack, []
        for msg in msgs:
            self.send(msg, ch)
        if self._reboot_after_ack:
            self._reboot_after_ack = False
            self.reboot()

    def _command(self, cmd, p, ch, m, frame, x, y) -> int:
        if cmd in LINK_COMMANDS:
            return self._link_command(cmd, p, ch)
        if cmd == mav.MAV_CMD_DO_SET_MISSION_CURRENT:
            return self.missions.command_set_current(p)
        return int(self.ap.command(cmd, p, frame, x, y))

    def _link_command(self, cmd, p, ch) -> int:
        if cmd == mav.MAV_CMD_DO_SEND_BANNER:      # ArduPilot: the banner, on this link only
            self._after_ack += [self._statustext_msg(mav.MAV_SEVERITY_INFO, line)
                                for line in version.banner(self.ap.kind, self.ap.sysid)]
            return mav.MAV_RESULT_ACCEPTED
        if not all(math.isfinite(v) for v in p[:2]):
            return mav.MAV_RESULT_DENIED
        if cmd == mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN:
            return self._reboot_command(p)
        if cmd == mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            if p[0] != 1:                  # ArduPilot: param1 1 asks for the version
                return mav.MAV_RESULT_FAILED
            self._after_ack.append(self.telemetry.autopilot_version())
            return mav.MAV_RESULT_ACCEPTED
        if not 0 <= p[0] <= 2**24 - 1:          # MAVLink 2 message ids are 24 bits
            return mav.MAV_RESULT_DENIED
        msgid = int(p[0])
        if cmd == mav.MAV_CMD_REQUEST_MESSAGE:
            # ArduPilot: an id it has no ap_message for -> FAILED; a known one -> ACCEPTED, and
            # the message follows when there is one to send (HOME_POSITION / GPS_GLOBAL_ORIGIN
            # before home / the origin are set: ACCEPTED, nothing sent)
            if msgid not in self.telemetry.builders:
                return mav.MAV_RESULT_FAILED
            msg = self.telemetry.build(msgid)
            if msg is not None:
                self._after_ack.append(msg)
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_GET_MESSAGE_INTERVAL:
            if msgid not in self.telemetry.builders:
                return mav.MAV_RESULT_DENIED
            iv = self.schedule.get(msgid)
            self._after_ack.append(mav.MAVLink_message_interval_message(msgid, -1 if iv is None else int(iv * 1e6)))
            return mav.MAV_RESULT_ACCEPTED
        # SET_MESSAGE_INTERVAL: p2 interval us; -1 disable; 0 default
        if msgid not in self.telemetry.builders or msgid == mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            self.statustext(mav.MAV_SEVERITY_INFO, f"No ap_message for mavlink id ({msgid})"[:50])
            return mav.MAV_RESULT_DENIED
        us = p[1]
        if us > MAX_INTERVAL_US:
            return mav.MAV_RESULT_DENIED
        if us == 0:
            self.intervals.pop(msgid, None)
        elif us < 0:
            self.intervals[msgid] = -1.0
        else:
            self.intervals[msgid] = max(us * 1e-6, 0.001)
        self._rebuild_schedule()
        return mav.MAV_RESULT_ACCEPTED

    # ----- reboot ---------------------------------------------------------------------------
    def _reboot_command(self, p) -> int:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN as ArduPilot (GCS_Common.cpp): refused while armed
        (FAILED, checked first); param1 1 reboots, 3 (into the bootloader) reboots the same here
        (no bootloader to hold in); anything else UNSUPPORTED. The ACK goes out first, from the
        old sysid."""
        if self.ap.armed:
            return mav.MAV_RESULT_FAILED
        if p[0] not in (1, 3):
            return mav.MAV_RESULT_UNSUPPORTED
        self._reboot_after_ack = True
        return mav.MAV_RESULT_ACCEPTED

    def reboot(self) -> None:
        """Reboot the simulated vehicle: the autopilot re-reads its parameters and starts
        afresh (modes, home, targets, failsafes); the link takes the new SYSID_THISMAV and
        forgets message intervals and queued replies. Peers and the world clock stay (the
        world's clock is every vehicle's time_boot_ms, so it does not restart)."""
        self.ap.reboot()
        self.mav.srcSystem = self.ap.sysid
        self.intervals.clear()
        self._origin_sent = None               # a new boot says its EKF origin again
        if self._ftp is not None:              # and has no MAVFTP session open
            self._ftp.close()
        self._ftp = None
        for q in self.outboxes.values():
            q.clear()
        self.outboxes.clear()
        self._rebuild_schedule()
        if self.logs is not None:              # the old boot's log closes
            self.logs.rebooted()
        self.stats["reboots"] += 1

    def on_SET_MODE(self, m, ch) -> None:
        if m.base_mode & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            result = mav.MAV_RESULT_ACCEPTED if self.ap.set_mode(m.custom_mode) else mav.MAV_RESULT_FAILED
        else:
            result = mav.MAV_RESULT_DENIED
        self.ack(ch, mav.MAVLINK_MSG_ID_SET_MODE, result, m)

    def on_SET_POSITION_TARGET_LOCAL_NED(self, m, ch) -> None:
        self.ap.position_target_local(m.coordinate_frame, m.type_mask, (m.x, m.y, m.z), (m.vx, m.vy, m.vz),
                                      (m.afx, m.afy, m.afz), m.yaw, m.yaw_rate)

    def on_SET_POSITION_TARGET_GLOBAL_INT(self, m, ch) -> None:
        self.ap.position_target_global(m.coordinate_frame, m.type_mask, m.lat_int, m.lon_int, m.alt,
                                       (m.vx, m.vy, m.vz), (m.afx, m.afy, m.afz), m.yaw, m.yaw_rate)

    def on_SET_ATTITUDE_TARGET(self, m, ch) -> None:
        self.ap.attitude_target(m.type_mask, m.q, (m.body_roll_rate, m.body_pitch_rate, m.body_yaw_rate), m.thrust)

    def on_GLOBAL_POSITION_INT(self, m, ch) -> None:
        """Another vehicle's position: FOLLOW's lead, when FOLL_ENABLE is set (AP_Follow)."""
        self.ap.follow.on_global_position(m.get_srcSystem(), m, self.ap.t, self.ap.home_lla()[2])

    def on_SET_GPS_GLOBAL_ORIGIN(self, m, ch) -> None:
        """As ArduPilot's handle_set_gps_global_origin: a bad latitude/longitude is dropped
        silently; the origin is set only if it is not set yet (then GPS_GLOBAL_ORIGIN goes out
        from update()); a second one is ignored, also silently. Altitude is mm AMSL."""
        lat, lon, alt = m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3
        if abs(lat) > 90 or abs(lon) > 180:
            return
        self.ap.local_origin.set(lat, lon, alt)
    _ftp: ftp.FtpServer | None = None

    def on_FILE_TRANSFER_PROTOCOL(self, m, ch) -> None:
        """MAVFTP (vehicle/link/ftp.py): the vehicle's root directory and @PARAM/param.pck."""
        if self._ftp is None:
            self._ftp = ftp.FtpServer({"@PARAM/param.pck": self._param_pck}, root=self.files_root.path())
        for reply in self._ftp.handle(m.payload, m.get_srcSystem(), m.get_srcComponent(), ch):
            self.send(mav.MAVLink_file_transfer_protocol_message(0, m.get_srcSystem(), m.get_srcComponent(),
                                                                 list(reply)), ch)

    def _param_pck(self, with_defaults: bool) -> bytes:
        ps = self.ap.params
        return ftp.param_pck([(n, ps[n], ps.defs[n].mav_type, ps.defs[n].default) for n in ps.names],
                             with_defaults)

    def on_TIMESYNC(self, m, ch) -> None:
        # a request (tc1 0): answer tc1 = our sim clock in ns (never 0, which would read as a
        # request), ts1 echoed; the sender gets its round trip from ts1 on its own clock
        if m.tc1 == 0:
            self.send(mav.MAVLink_timesync_message(max(1, int(self.clock() * 1e9)), m.ts1), ch)

    def on_REQUEST_DATA_STREAM(self, m, ch) -> None:
        rate = m.req_message_rate if m.start_stop else 0
        groups = list(DATA_STREAMS.values()) if m.req_stream_id == mav.MAV_DATA_STREAM_ALL \
            else [DATA_STREAMS.get(m.req_stream_id)]
        for g in groups:
            if g is not None:
                self.ap.params.set(g, min(max(rate, 0), 50), save=False)
        self._rebuild_schedule()

    # ----- parameters ------------------------------------------------------------------------
    def param_value(self, name: str):
        ps = self.ap.params
        return mav.MAVLink_param_value_message(name.encode(), float(ps[name]), ps.defs[name].mav_type,
                                               len(ps), ps.index[name])

    def on_PARAM_REQUEST_LIST(self, m, ch) -> None:
        # ArduPilot: a new request restarts this peer's list from the first parameter (one
        # list in flight per peer, however many requests arrive), sent paced
        self.paced(ch).start_stream("params", self._param_stream())

    def _param_stream(self):
        signed = bool(self.signing_key)
        for name in list(self.ap.params.names):
            if name in self.ap.params:           # the value as it is when it goes out
                msg = self.param_value(name)
                yield msg, wire_size(msg, signed)

    def on_PARAM_REQUEST_READ(self, m, ch) -> None:
        ps = self.ap.params
        if m.param_index >= 0:
            if m.param_index >= len(ps):
                return
            name = ps.names[m.param_index]
        else:
            name = _param_id(m.param_id)
            if name not in ps:
                return
        self.send_paced(self.param_value(name), ch)

    def on_PARAM_SET(self, m, ch) -> None:
        ps = self.ap.params
        name = _param_id(m.param_id)
        if name not in ps:
            text = f"Param set: unknown {name}"[:50]
            self.broadcast_once(("text", text), lambda: self._statustext_msg(mav.MAV_SEVERITY_WARNING, text))
            return
        why = ps.set(name, float(m.param_value))
        if why is not None:
            text = why[:50]
            self.broadcast_once(("text", text), lambda: self._statustext_msg(mav.MAV_SEVERITY_WARNING, text))
            self.send(self.param_value(name), ch)
            return
        self.broadcast_once(("param", name), lambda: self.param_value(name))
        if name.startswith("SR0_"):
            self._rebuild_schedule()
        self.params_changed({name: ps[name]})
