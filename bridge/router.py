"""The bridge router: one select loop that routes, translates, streams frames and follows.

Links
    ``tower``    the tower GCS; its link is in the tower frame (translated both ways)
    ``drone``    vehicle sysid 1 (world frame)
    ``rover``    vehicle sysid 2 (world frame)
    ``outN``     extra GCS-side endpoints (``--out``): world frame, untranslated; they
                 get everything the tower gets (telemetry, transform stream, status)

Routing (mavlink-router / ArduPilot semantics)
    Every valid packet from a vehicle goes to the GCS-side links (tower, outs), and to
    another vehicle only when that vehicle is its target. A packet from a GCS-side
    link goes to the links whose systems match its target_system (vehicle links own
    their configured sysid from the start, and learn any sysid they carry);
    target_system 0 is a broadcast to every other link. Packets are forwarded as the
    raw bytes received (sysid, compid, seq, signature untouched); only messages that
    are translated are re-encoded, with the same sysid, compid and seq.

Translation on the tower link (``--tower-frame``, default ``tower``)
    tower -> vehicle: SET_POSITION_TARGET_LOCAL_NED in LOCAL_NED / LOCAL_OFFSET_NED
    is mapped tower -> world (bridge.translate). vehicle -> tower: LOCAL_POSITION_NED and
    POSITION_TARGET_LOCAL_NED are mapped world -> tower. If the transform is not
    available a goal waits and is retried every tick (STATUSTEXT + log say why); a
    telemetry message is dropped (counted) rather than sent in the wrong frame.

One timeline (bridge.timeline)
    Each vehicle's stamps (time_boot_ms) are mapped onto the clock of the first vehicle
    seen before they enter the buffer, the follow logic and the transform stream, using
    the clock offsets learned from the vehicles' SYSTEM_TIME (vehicles of one world have
    one offset: unchanged stamps). While a vehicle's timeline is not known (its or the
    reference's SYSTEM_TIME not seen yet) its samples are held back in a queue and the
    bridge asks for SYSTEM_TIME; they are released mapped once it is known, or raw after
    --time-grace wall seconds without it (a peer that does not send SYSTEM_TIME is taken
    to share the reference's world; logged). TIMESYNC probes (1 Hz wall) measure each
    vehicle link's round trip (logged, and in the summary); they do not move stamps.
"""
from __future__ import annotations

import math
import selectors
from collections import deque
import sys
import time
from dataclasses import dataclass, field, replace

from gcs.dialect import encoder
from gcs.dialect import towerlink as tl
from bridge.follow import FollowSupervisor, ground_points
from gcs.frames import LATEST, Buffer, TransformException, TransformStamped
from gcs.mavstr import mav_str as _s
from gcs.modes import ROVER_GUIDED, ROVER_HOLD
from bridge.links import Link, Packet
from bridge.tf_stream import VehicleFrames, reset_edge, transform_message
from bridge.timeline import Timeline, TimesyncProbe
from bridge import translate

MSG_HEARTBEAT = 0
MSG_SYSTEM_TIME = 2
MSG_TIMESYNC = 111
MSG_ATTITUDE_QUATERNION = 31
MSG_LOCAL_POSITION_NED = 32
MSG_SET_POSITION_TARGET_LOCAL_NED = 84
MSG_POSITION_TARGET_LOCAL_NED = 85
MSG_TL_TRANSFORM = 43000
MSG_TL_STATIC = 43001
MSG_TL_TARGET = 43002

TICK = 0.01                     # wall s between upkeep passes
STATIC_PERIOD = 1.0             # wall s between republishing static transforms
STATUS_PERIOD = 1.0
TIMESYNC_PERIOD = 1.0           # wall s between TIMESYNC probes of each vehicle link
RTT_LOG_PERIOD = 30.0           # wall s between round-trip log lines of a link
HOLD_MAX = 256                  # samples queued per vehicle while its timeline is unknown


@dataclass
class BridgeConfig:
    tower: str = "udpin:127.0.0.1:14600"
    drone: str | None = "udpout:127.0.0.1:14560"
    rover: str | None = "udpout:127.0.0.1:14570"
    outs: list = field(default_factory=list)
    drone_sysid: int = 1
    rover_sysid: int = 2
    sysid: int = 250
    compid: int = 191           # MAV_COMP_ID_ONBOARD_COMPUTER
    tower_frame: str = "tower"
    world_frame: str = "world"
    statics: list = field(default_factory=list)   # TransformStamped
    follow: bool = True
    follow_frame: str = "drone_yaw"
    follow_offset: tuple = (0.0, 0.0)
    follow_rate: float = 10.0
    follow_timeout: float = 1.0
    follow_ff: bool = True
    speedup: float = 1.0
    telemetry_rate: float = 20.0
    tf_rate: float = 20.0
    cache_time: float = 10.0
    max_transform_age: float = 0.5
    time_grace: float = 1.5     # wall s to wait for a vehicle's SYSTEM_TIME before presuming one world
    quiet: bool = False


@dataclass
class Vehicle:
    name: str
    sysid: int
    link: Link
    frames: VehicleFrames
    custom_mode: int | None = None
    armed: bool = False
    last_heartbeat_wall: float | None = None
    newest_stamp: float | None = None
    newest_stamp_wall: float | None = None
    last_tf_pub: float | None = None
    last_att_wall: float = -1e9
    last_pos_wall: float = -1e9
    last_stream_req: float = -1e9
    position: tuple | None = None       # latest world (x, y, z)
    probe: TimesyncProbe = field(default_factory=TimesyncProbe)
    last_rtt_log: float = -1e9
    held: int = 0                       # samples held back (timeline unknown), in all
    queue: deque = field(default_factory=lambda: deque(maxlen=HOLD_MAX))
    offset_logged: bool = False
    last_mapped: float | None = None    # newest frame stamp on the reference timeline
    last_time_req: float = -1e9


@dataclass
class PendingGoal:
    kind: str                # "spt" (SET_POSITION_TARGET_LOCAL_NED) or "named"
    msg: object
    src: tuple               # (sysid, compid, seq, v2)
    frame: str
    target: int
    since: float
    last_warn: float = -1e9
    attempts: int = 0


class Bridge:
    def __init__(self, cfg: BridgeConfig, clock=time.monotonic, log=None) -> None:
        self.cfg = cfg
        self.clock = clock
        self._log = log
        self.t0 = clock()
        self.buffer = Buffer(cache_time=cfg.cache_time)
        self.static_added: dict[str, tuple[TransformStamped, str]] = {}
        for ts in cfg.statics:
            self.buffer.set_transform_static(ts, authority="scenario")
            self.static_added[ts.child_frame_id] = (ts, "scenario")
        self.tower = Link("tower", cfg.tower, clock)
        self.outs = [Link(f"out{i}", url, clock) for i, url in enumerate(cfg.outs)]
        self.gcs_links = [self.tower, *self.outs]
        self.vehicles: dict[int, Vehicle] = {}
        for name, url, sysid in (("drone", cfg.drone, cfg.drone_sysid),
                                 ("rover", cfg.rover, cfg.rover_sysid)):
            if url:
                link = Link(name, url, clock)
                link.sysids.add(sysid)
                self.vehicles[sysid] = Vehicle(name, sysid, link, VehicleFrames(name, cfg.world_frame))
        self.links = [*self.gcs_links, *(v.link for v in self.vehicles.values())]
        self.enc = encoder(cfg.sysid, cfg.compid)       # the bridge's own messages
        self.reenc = encoder(0, 0)                      # re-encoding others' messages
        self.dec = tl.MAVLink(None)
        self.dec.robust_parsing = True
        self.pending: dict[int, PendingGoal] = {}
        self.follow = FollowSupervisor(cfg.follow_timeout, cfg.speedup, cfg.follow_rate)
        self.timeline = Timeline(speedup=cfg.speedup, grace=cfg.time_grace)
        self._next_timesync = 0.0
        self.follow_state = tl.TOWERLINK_FOLLOW_STATE_WAITING
        self.follow_ticks = 0
        self.last_goal = None
        self.decode_errors = 0
        self.tower_drops = 0
        self._next_static = 0.0
        self._next_status = 0.0
        self._next_hb = 0.0
        self._last_mode_cmd = -1e9
        self._last_arm_cmd = -1e9
        self.rover_mode_wanted: int | None = None
        self._warned: dict[str, float] = {}
        self.running = True
        self.sel = selectors.DefaultSelector()
        self._registered: dict = {}

    # ------------------------------------------------------------------ logging
    def log(self, text: str) -> None:
        if self._log is not None:
            self._log(text)
        elif not self.cfg.quiet:
            print(f"[bridge {self.clock() - self.t0:8.3f}] {text}", file=sys.stderr, flush=True)

    def warn_once(self, key: str, text: str, period: float = 2.0) -> bool:
        now = self.clock()
        if now - self._warned.get(key, -1e9) >= period:
            self._warned[key] = now
            self.log(text)
            return True
        return False

    # ------------------------------------------------------------------ sending
    def _pack_own(self, msg) -> bytes:
        b = msg.pack(self.enc)
        self.enc.seq = (self.enc.seq + 1) % 256
        return b

    def _pack_as(self, msg, src: tuple) -> bytes:
        sysid, compid, seq, v2 = src
        e = self.reenc
        e.srcSystem, e.srcComponent, e.seq = sysid, compid, seq
        return msg.pack(e, force_mavlink1=not v2)

    def to_gcs(self, data: bytes, tower: bool = True) -> None:
        for link in (self.gcs_links if tower else self.outs):
            link.send(data)

    def send_own_to_gcs(self, msg) -> None:
        self.to_gcs(self._pack_own(msg))

    def statustext(self, text: str, severity: int = tl.MAV_SEVERITY_WARNING) -> None:
        self.send_own_to_gcs(tl.MAVLink_statustext_message(severity, text[:50].encode()))

    def to_vehicle(self, target: int, data: bytes, exclude: Link | None = None) -> bool:
        sent = False
        if target == 0:
            for v in self.vehicles.values():
                if v.link is not exclude:
                    v.link.send(data)
                    sent = True
            return sent
        for v in self.vehicles.values():
            if target in v.link.sysids and v.link is not exclude:
                v.link.send(data)
                sent = True
        return sent

    def command_long(self, target: int, command: int, *params) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        msg = tl.MAVLink_command_long_message(target, 1, command, 0, *p)
        self.to_vehicle(target, self._pack_own(msg))

    # ------------------------------------------------------------------ routing
    def route_from_gcs(self, link: Link, pkt: Packet) -> None:
        t = pkt.target_system
        if t == 0:
            for other in self.links:
                if other is not link:
                    other.send(pkt.raw)
            return
        if t == self.cfg.sysid:
            return
        sent = False
        for other in self.links:
            if other is not link and t in other.sysids:
                other.send(pkt.raw)
                sent = True
        if not sent:
            link.stats.unroutable += 1

    def route_from_vehicle(self, v: Vehicle, pkt: Packet, to_tower: bytes | None) -> None:
        t = pkt.target_system
        if t == self.cfg.sysid:
            return
        if to_tower is not None:
            self.tower.send(to_tower)
        for o in self.outs:
            o.send(pkt.raw)
        if t:
            for other in self.vehicles.values():
                if other is not v and t in other.link.sysids:
                    other.link.send(pkt.raw)

    def decode(self, pkt: Packet):
        try:
            return self.dec.decode(bytearray(pkt.raw))
        except Exception:
            self.decode_errors += 1
            return None

    # ------------------------------------------------------------------ packets in
    def on_packet(self, link: Link, pkt: Packet) -> None:
        v = self.vehicles.get(pkt.sysid) if link.name in ("drone", "rover") else None
        if link in self.gcs_links:
            self.on_gcs_packet(link, pkt)
            return
        if v is None:
            # a system behind a vehicle link that is not the configured one (e.g. a camera)
            for cand in self.vehicles.values():
                if cand.link is link:
                    self.route_from_vehicle(cand, pkt, pkt.raw)
                    return
            return
        self.on_vehicle_packet(v, pkt)

    def on_gcs_packet(self, link: Link, pkt: Packet) -> None:
        link.sysids.add(pkt.sysid)
        mid = pkt.msgid
        if mid == MSG_SET_POSITION_TARGET_LOCAL_NED and link is self.tower:
            msg = self.decode(pkt)
            if msg is None:
                link.stats.malformed += 1
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES:
                self.submit_goal(PendingGoal("spt", msg, (pkt.sysid, pkt.compid, pkt.seq, pkt.v2),
                                             self.cfg.tower_frame, msg.target_system, self.clock()))
                return
        elif mid == MSG_TL_TARGET:
            msg = self.decode(pkt)
            if msg is None:
                link.stats.malformed += 1
                return
            frame = _s(msg.frame_id)
            self.submit_goal(PendingGoal("named", msg, (pkt.sysid, pkt.compid, pkt.seq, True),
                                         frame, msg.target_system, self.clock()))
            return
        elif mid == MSG_TL_STATIC:
            msg = self.decode(pkt)
            if msg is None:
                link.stats.malformed += 1
                return
            if msg.target_system in (0, self.cfg.sysid):
                self.add_static(msg, pkt.sysid)
            return
        elif mid == MSG_TL_TRANSFORM:
            return   # transform streams are ours to publish; do not echo them to vehicles
        self.route_from_gcs(link, pkt)

    def on_vehicle_packet(self, v: Vehicle, pkt: Packet) -> None:
        mid = pkt.msgid
        now = self.clock()
        to_tower = pkt.raw
        if mid == MSG_LOCAL_POSITION_NED:
            msg = self.decode(pkt)
            if msg is None:
                return
            v.last_pos_wall = now
            v.position = (msg.x, msg.y, msg.z)
            self._raw_clock(v, msg.time_boot_ms / 1000.0, now)
            for s in v.frames.on_local_position(msg.time_boot_ms, msg.x, msg.y, msg.z,
                                                 msg.vx, msg.vy, msg.vz):
                self.on_frame_sample(v, s)
            to_tower = self.translate_to_tower(msg, pkt, translate.local_position)
        elif mid == MSG_POSITION_TARGET_LOCAL_NED:
            msg = self.decode(pkt)
            if msg is None:
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES:
                to_tower = self.translate_to_tower(msg, pkt, translate.position_target)
        elif mid == MSG_ATTITUDE_QUATERNION:
            msg = self.decode(pkt)
            if msg is None:
                return
            v.last_att_wall = now
            self._raw_clock(v, msg.time_boot_ms / 1000.0, now)
            for s in v.frames.on_attitude_quaternion(msg.time_boot_ms, msg.q1, msg.q2, msg.q3, msg.q4):
                self.on_frame_sample(v, s)
        elif mid == MSG_SYSTEM_TIME and pkt.compid == 1:
            msg = self.decode(pkt)
            if msg is not None:
                self.on_system_time(v, msg, now)
        elif mid == MSG_TIMESYNC:
            msg = self.decode(pkt)
            if msg is not None and self.on_timesync(v, msg, now):
                return          # the answer to our own probe: not forwarded
        elif mid == MSG_HEARTBEAT and pkt.compid == 1:
            msg = self.decode(pkt)
            if msg is not None:
                first = v.last_heartbeat_wall is None
                v.custom_mode = msg.custom_mode
                v.armed = bool(msg.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED)
                v.last_heartbeat_wall = now
                if first:
                    self.log(f"{v.name} (sysid {v.sysid}) is up: mode {msg.custom_mode}, "
                             f"{'armed' if v.armed else 'disarmed'}")
                    self.request_streams(v, force=True)
                    self.request_system_time(v, force=True)
        self.route_from_vehicle(v, pkt, to_tower)

    # ------------------------------------------------------------------ timeline
    def _raw_clock(self, v: Vehicle, boot_s: float, now: float) -> None:
        """A vehicle's raw boot-clock reading: feed the timeline, track its mapped clock."""
        if self.timeline.clock(v.name, boot_s, now):
            self.log(f"{v.name}: clock went back to {boot_s:.3f} s (restart): its clock offset is "
                     f"re-learned from SYSTEM_TIME")
            self.request_system_time(v, force=True)
        if not self._hold(v, ("clock", boot_s, now)):
            self._clock_seen(v, self.timeline.to_ref(v.name, boot_s), now)

    def _hold(self, v: Vehicle, item) -> bool:
        """Queue `item` if v's timeline is unknown (or earlier items still wait); True if held."""
        if self.timeline.shift(v.name) is not None and not v.queue:
            return False
        if not v.queue:
            d = self.timeline.clock_disagreement(v.name, self.timeline.clocks[v.name].newest, self.clock())
            why = f"its clock reads {d:+.2f} s against {self.timeline.ref}'s" if d is not None else "-"
            self.warn_once(f"hold-{v.name}", f"{v.name}: samples held back until SYSTEM_TIME puts it on "
                                             f"{self.timeline.ref}'s timeline ({why})", period=10.0)
            self.request_system_time(v)
        v.held += 1
        v.queue.append(item)
        return True

    def release_held(self) -> None:
        """Replay the queued samples of vehicles whose timeline became known, in order."""
        for key in self.timeline.expire(self.clock()):
            self.log(f"{key}: no SYSTEM_TIME within {self.timeline.grace:g} s: presumed to share "
                     f"{self.timeline.ref}'s world, its stamps are used as they are")
        for v in self.vehicles.values():
            if not v.queue:
                continue
            shift = self.timeline.shift(v.name)
            if shift is None:
                continue
            n = len(v.queue)
            while v.queue:
                item = v.queue.popleft()
                if item[0] == "clock":
                    self._clock_seen(v, item[1] + shift, item[2])
                else:
                    self._frame_on_timeline(v, item[1], shift)
            self.log(f"{v.name}: {n} held samples released onto {self.timeline.ref}'s timeline "
                     f"({self.timeline.basis(v.name)}, shift {shift:+.3f} s)")

    def on_system_time(self, v: Vehicle, msg, now: float) -> None:
        line = self.timeline
        before = line.basis(v.name)
        old = line.system_time(v.name, msg.time_unix_usec, msg.time_boot_ms, now)
        off = line.offset(v.name)
        if off is None:
            self.warn_once(f"no-unix-{v.name}", f"{v.name}: SYSTEM_TIME without unix time: "
                                                f"its clock offset stays unknown", period=60.0)
            return
        if old is not None:
            self.log(f"{v.name}: clock offset changed by {off - old:+.3f} s (another clock)")
        if old is not None or line.basis(v.name) != before or not v.offset_logged:
            v.offset_logged = True
            shift = line.shift(v.name)
            if v.name == line.ref:
                where = "its clock is the reference timeline"
            elif shift is not None:
                where = f"mapped onto {line.ref}'s timeline by {shift:+.3f} s ({line.basis(v.name)})"
            else:
                where = f"waiting for {line.ref}'s SYSTEM_TIME"
            self.log(f"{v.name}: SYSTEM_TIME: booted at unix {off:.3f} s; {where}")
        self.release_held()

    def request_system_time(self, v: Vehicle, force: bool = False) -> None:
        now = self.clock()
        if not force and now - v.last_time_req < 1.0:
            return
        v.last_time_req = now
        self.command_long(v.sysid, tl.MAV_CMD_REQUEST_MESSAGE, MSG_SYSTEM_TIME)

    def on_timesync(self, v: Vehicle, msg, now: float) -> bool:
        rtt = v.probe.reply(msg.tc1, msg.ts1, int(now * 1e9))
        if rtt is None:
            return False
        if v.probe.count == 1 or now - v.last_rtt_log >= RTT_LOG_PERIOD:
            v.last_rtt_log = now
            self.log(f"{v.name}: TIMESYNC round trip {rtt * 1e3:.2f} ms "
                     f"(min {v.probe.rtt_min * 1e3:.2f} ms, {v.probe.count} probes)")
        return True

    def _clock_seen(self, v: Vehicle, stamp: float, now: float) -> None:
        if v.newest_stamp is None or stamp > v.newest_stamp or stamp < v.newest_stamp - 1.0:
            v.newest_stamp = stamp
            v.newest_stamp_wall = now

    def translate_to_tower(self, msg, pkt: Packet, fn) -> bytes | None:
        if not self.tower.connected:
            return None
        try:
            T = self.buffer.lookup_transform(self.cfg.tower_frame, self.cfg.world_frame, LATEST)
        except TransformException as exc:
            self.tower_drops += 1
            self.warn_once("to-tower", f"telemetry to the tower dropped: no {self.cfg.world_frame} -> "
                                       f"{self.cfg.tower_frame} transform ({exc})")
            return None
        self.tower.stats.translated += 1
        return self._pack_as(fn(msg, T.transform), (pkt.sysid, pkt.compid, pkt.seq, pkt.v2))

    # ------------------------------------------------------------------ frames
    def on_frame_sample(self, v: Vehicle, s) -> None:
        # onto the reference timeline first: buffer, stream and follow see one clock
        if not self._hold(v, ("frame", s)):
            self._frame_on_timeline(v, s, self.timeline.shift(v.name))

    def _frame_on_timeline(self, v: Vehicle, s, shift: float) -> None:
        if shift:
            t = s.stamp + shift
            s = replace(s, stamp=t, full=replace(s.full, stamp=t), yaw=replace(s.yaw, stamp=t))
        if v.last_mapped is not None and s.stamp < v.last_mapped - 1.0:
            s = replace(s, reset=True)      # its mapped clock went back (a restart elsewhere)
        if s.reset or v.last_mapped is None or s.stamp > v.last_mapped:
            v.last_mapped = s.stamp
        try:
            if s.reset:
                self.log(f"{v.name}: clock went back to {s.stamp:.3f} s (reboot): its frames are reset")
                reset_edge(self.buffer, s.full, v.name)
                reset_edge(self.buffer, s.yaw, v.name)
            else:
                self.buffer.set_transform(s.full, authority=v.name)
                self.buffer.set_transform(s.yaw, authority=v.name)
        except TransformException as exc:
            self.warn_once(f"set-{v.name}", f"{v.name}: transform rejected: {exc}")
            return
        if s.reset:
            v.last_tf_pub = None
        if v.last_tf_pub is None or s.stamp >= v.last_tf_pub + 0.5 / self.cfg.tf_rate - 1e-6 \
                or s.stamp < v.last_tf_pub:
            v.last_tf_pub = s.stamp
            self.send_own_to_gcs(transform_message(s.full))
            self.send_own_to_gcs(transform_message(s.yaw))
        if v.sysid == self.cfg.drone_sysid and self.cfg.follow and self.cfg.rover_sysid in self.vehicles:
            if self.follow.on_drone_sample(s.stamp, self.clock()):
                self.follow_tick(s.stamp, s.velocity)

    def add_static(self, msg, src_sysid: int) -> None:
        try:
            from bridge.tf_stream import transform_from_message
            ts, _ = transform_from_message(msg)
            ts = TransformStamped(ts.frame_id, ts.child_frame_id, 0.0, ts.transform)
            dynamic = {v.name for v in self.vehicles.values()} | \
                      {v.name + "_yaw" for v in self.vehicles.values()}
            if ts.child_frame_id in dynamic or ts.child_frame_id == self.cfg.world_frame:
                raise ValueError(f"{ts.child_frame_id!r} is a frame the bridge owns")
            self.buffer.set_transform_static(ts, authority=f"static-transform:{src_sysid}")
        except (TransformException, ValueError) as exc:
            self.log(f"static transform from sysid {src_sysid} refused: {exc}")
            self.statustext(f"static tf refused: {exc}", tl.MAV_SEVERITY_ERROR)
            return
        self.static_added[ts.child_frame_id] = (ts, f"static-transform:{src_sysid}")
        self.log(f"static transform {ts.frame_id} -> {ts.child_frame_id} added by sysid {src_sysid}")
        self.statustext(f"static tf {ts.frame_id}->{ts.child_frame_id} added", tl.MAV_SEVERITY_INFO)
        self.send_own_to_gcs(transform_message(ts, static=True))

    def world_clock(self) -> float | None:
        stamps = [v.newest_stamp for v in self.vehicles.values() if v.newest_stamp is not None]
        return max(stamps) if stamps else None

    def fresh_lookup(self, target: str, source: str):
        """lookup_transform(target, source, LATEST), refusing stale dynamic chains.

        A chain with a dynamic edge is usable only if its latest common time is within
        max_transform_age of the newest vehicle clock seen; otherwise it would be a guess.
        """
        T = self.buffer.lookup_transform(target, source, LATEST)
        chain = self.buffer.chain(target, source)
        stats = self.buffer.edge_stats()
        dynamic = any(f in stats and not stats[f].is_static for f in chain)
        if dynamic:
            now = self.world_clock()
            if now is not None and T.stamp < now - self.cfg.max_transform_age:
                raise StaleTransform(f"{source} -> {target} is {now - T.stamp:.2f} s old "
                                     f"(max {self.cfg.max_transform_age} s)")
        return T

    # ------------------------------------------------------------------ goals
    def submit_goal(self, g: PendingGoal) -> None:
        self.pending[g.target] = g          # a newer goal supersedes a waiting one
        self.try_goal(g)

    def try_goal(self, g: PendingGoal) -> bool:
        g.attempts += 1
        try:
            T = self.fresh_lookup(self.cfg.world_frame, g.frame).transform
        except (TransformException, StaleTransform) as exc:
            self.tower.stats.deferred += 1
            now = self.clock()
            if now - g.last_warn >= 1.0:
                g.last_warn = now
                self.log(f"goal for sysid {g.target} in {g.frame!r} waits: {exc}")
                self.statustext(f"goal waits: no {g.frame}->world tf")
            return False
        if g.kind == "spt":
            out = translate.set_position_target(g.msg, T)
        else:
            out = translate.named_target(g.msg, T)
        data = self._pack_as(out, g.src)
        if not self.to_vehicle(g.target, data):
            self.tower.stats.unroutable += 1
        else:
            self.tower.stats.translated += 1
        if self.pending.get(g.target) is g:
            del self.pending[g.target]
        if g.attempts > 1:
            self.log(f"goal for sysid {g.target} in {g.frame!r} sent after {g.attempts} attempts")
        return True

    # ------------------------------------------------------------------ follow
    def follow_tick(self, stamp: float, velocity) -> None:
        cfg = self.cfg
        try:
            Tf = self.buffer.lookup_transform(cfg.world_frame, "drone", stamp)
            Ty = self.buffer.lookup_transform(cfg.world_frame, "drone_yaw", stamp)
        except TransformException as exc:
            self.warn_once("follow-lookup", f"follow: no drone transform at {stamp:.3f}: {exc}")
            return
        gp = ground_points(Tf.transform, Ty.transform, cfg.follow_offset, stamp)
        gx, gy = gp.goal(cfg.follow_frame)
        if self.follow.holding:
            self.follow.holding = False
            self.log("follow: drone telemetry is back; rover resumes following")
            self.statustext("follow: resumed", tl.MAV_SEVERITY_INFO)
        self.follow_state = tl.TOWERLINK_FOLLOW_STATE_FOLLOWING
        rover = self.vehicles[cfg.rover_sysid]
        vx, vy = (velocity[0], velocity[1]) if cfg.follow_ff else (0.0, 0.0)
        mask = translate.IGNORE_ACC | translate.IGNORE_YAW | translate.IGNORE_YAW_RATE
        if not cfg.follow_ff:
            mask |= translate.IGNORE_VEL
        msg = tl.MAVLink_set_position_target_local_ned_message(
            int(round(stamp * 1000)) & 0xFFFFFFFF, rover.sysid, 1, tl.MAV_FRAME_LOCAL_NED, mask,
            gx, gy, 0.0, vx, vy, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        rover.link.send(self._pack_own(msg))
        self.follow_ticks += 1
        self.last_goal = (gx, gy)
        self.want_rover_mode(ROVER_GUIDED)
        rp = rover.position or (math.nan, math.nan)
        self.send_own_to_gcs(tl.MAVLink_towerlink_follow_status_message(
            int(round(stamp * 1e6)), gp.ref[0], gp.ref[1], gp.full[0], gp.full[1], gp.yaw[0],
            gp.yaw[1], gx, gy, vx, vy, rp[0], rp[1], gp.height, gp.tilt, gp.err_full, gp.err_yaw,
            0 if cfg.follow_frame == "drone" else 1, self.follow_state))

    def want_rover_mode(self, mode: int) -> None:
        if self.rover_mode_wanted != mode:
            self.rover_mode_wanted = mode
            self._last_mode_cmd = -1e9
        self.ensure_rover_mode(mode, arm=(mode == ROVER_GUIDED))

    def ensure_rover_mode(self, mode: int, arm: bool = False) -> None:
        rover = self.vehicles.get(self.cfg.rover_sysid)
        if rover is None or rover.last_heartbeat_wall is None:
            return
        now = self.clock()
        if rover.custom_mode != mode and now - self._last_mode_cmd > 0.5:
            self._last_mode_cmd = now
            self.command_long(rover.sysid, tl.MAV_CMD_DO_SET_MODE,
                              tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
        if arm and not rover.armed and now - self._last_arm_cmd > 1.0:
            self._last_arm_cmd = now
            self.command_long(rover.sysid, tl.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    def check_follow_timeout(self) -> None:
        cfg = self.cfg
        if not cfg.follow or cfg.rover_sysid not in self.vehicles:
            return
        rover = self.vehicles[cfg.rover_sysid]
        now = self.clock()
        if not self.follow.holding and self.follow.stale(now, rover.newest_stamp, rover.newest_stamp_wall):
            self.follow.holding = True
            self.follow_state = tl.TOWERLINK_FOLLOW_STATE_HOLDING
            self.log(f"follow: no drone telemetry for > {cfg.follow_timeout} s (sim); rover to HOLD")
            self.statustext("follow: drone lost, rover HOLD")
            self.want_rover_mode(ROVER_HOLD)
        elif self.rover_mode_wanted is not None:
            self.ensure_rover_mode(self.rover_mode_wanted, arm=(self.rover_mode_wanted == ROVER_GUIDED))

    # ------------------------------------------------------------------ periodic
    def request_streams(self, v: Vehicle, force: bool = False) -> None:
        if self.cfg.telemetry_rate <= 0:
            return
        now = self.clock()
        if not force and now - v.last_stream_req < 5.0:
            return
        v.last_stream_req = now
        interval = 1e6 / self.cfg.telemetry_rate
        for mid in (MSG_LOCAL_POSITION_NED, MSG_ATTITUDE_QUATERNION):
            self.command_long(v.sysid, tl.MAV_CMD_SET_MESSAGE_INTERVAL, mid, interval)

    def tick(self) -> None:
        now = self.clock()
        for link in self.links:
            link.poll()
        self.release_held()
        for g in list(self.pending.values()):
            self.try_goal(g)
        self.check_follow_timeout()
        if now >= self._next_hb:
            self._next_hb = now + 1.0
            hb = tl.MAVLink_heartbeat_message(tl.MAV_TYPE_ONBOARD_CONTROLLER, tl.MAV_AUTOPILOT_INVALID,
                                              0, 0, tl.MAV_STATE_ACTIVE, 3)
            data = self._pack_own(hb)
            for v in self.vehicles.values():
                v.link.send(data)
                if v.last_heartbeat_wall is not None and (now - v.last_att_wall > 2.0 or now - v.last_pos_wall > 2.0):
                    self.request_streams(v)
        if now >= self._next_timesync:
            self._next_timesync = now + TIMESYNC_PERIOD
            for v in self.vehicles.values():
                ts1 = v.probe.request(int(now * 1e9))
                v.link.send(self._pack_own(tl.MAVLink_timesync_message(0, ts1)))
                if v.last_heartbeat_wall is not None and v.queue:
                    self.request_system_time(v)
        if now >= self._next_static:
            self._next_static = now + STATIC_PERIOD
            for ts, _auth in list(self.static_added.values()):
                self.send_own_to_gcs(transform_message(ts, static=True))
        if now >= self._next_status:
            self._next_status = now + STATUS_PERIOD
            usec = int((now - self.t0) * 1e6)
            for link in self.links:
                st = link.stats
                self.send_own_to_gcs(tl.MAVLink_towerlink_bridge_status_message(
                    usec, link.name.encode()[:16], st.rx_packets & 0xFFFFFFFF, st.tx_packets & 0xFFFFFFFF,
                    link.malformed & 0xFFFFFFFF, st.unroutable & 0xFFFFFFFF,
                    st.translated & 0xFFFFFFFF, st.deferred & 0xFFFFFFFF))

    # ------------------------------------------------------------------ loop
    def _sync_selector(self) -> None:
        want = {}
        for link in self.links:
            for s in link.fileobjs():
                want[s] = link
        for s in list(self._registered):
            if s not in want or s.fileno() < 0:
                try:
                    self.sel.unregister(s)
                except (KeyError, ValueError, OSError):
                    pass
                del self._registered[s]
        for s, link in want.items():
            if s not in self._registered:
                try:
                    self.sel.register(s, selectors.EVENT_READ, link)
                    self._registered[s] = link
                except (ValueError, OSError):
                    pass

    def run_once(self, timeout: float) -> None:
        self._sync_selector()
        for key, _ev in self.sel.select(timeout):
            link = key.data
            for pkt in link.on_readable(key.fileobj):
                try:
                    self.on_packet(link, pkt)
                except Exception as exc:   # never let one packet stop the router
                    link.stats.malformed += 1
                    self.warn_once("packet-error", f"packet {pkt.msgid} from {link.name} failed: {exc!r}")

    def run(self, duration: float | None = None) -> None:
        end = None if duration is None else self.clock() + duration
        next_tick = self.clock()
        while self.running:
            now = self.clock()
            if now >= next_tick:
                self.tick()
                next_tick = now + TICK
            if end is not None and now >= end:
                break
            self.run_once(max(0.0, next_tick - self.clock()))

    def stop(self, *_a) -> None:
        self.running = False

    def summary(self) -> str:
        parts = []
        for link in self.links:
            st = link.stats
            parts.append(f"{link.name}: rx {st.rx_packets} tx {st.tx_packets} malformed {link.malformed} "
                         f"unroutable {st.unroutable} translated {st.translated} deferred {st.deferred}")
        for v in self.vehicles.values():
            p = v.probe
            rtt = "-" if p.rtt is None else f"{p.rtt * 1e3:.2f} ms (min {p.rtt_min * 1e3:.2f} ms)"
            parts.append(f"{v.name}: timeline {self.timeline.basis(v.name)}; TIMESYNC round trip {rtt}; "
                         f"samples held back {v.held}")
        parts.append(f"follow ticks {self.follow_ticks}; decode errors {self.decode_errors}; "
                     f"tower telemetry dropped (no transform) {self.tower_drops}")
        return "\n".join(parts)

    def close(self) -> None:
        for link in self.links:
            link.close()
        self.sel.close()


class StaleTransform(Exception):
    """A dynamic transform chain whose latest common time is too old to use."""
