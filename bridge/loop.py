"""The bridge: one select loop that routes packets and hands each to the room that owns it.

Links
    ``tower``    the tower GCS; its link is in the tower frame (translated both ways)
    ``drone``    vehicle sysid 1 (world frame)
    ``rover``    vehicle sysid 2 (world frame)
    ``outN``     extra GCS-side endpoints (``--out``): world frame, untranslated; they
                 get everything the tower gets (telemetry, transform stream, status)
    ``nodes``    (``--nodes``) the link of tf2_ros-style nodes (common.tf2_ros): an out that
                 also takes their transforms (bridge.node_frames) and, with --route-only,
                 the tower's goals (tower frame, raw) for a node to transform

Routing (mavlink-router / ArduPilot semantics)
    Every valid packet from a vehicle goes to the GCS-side links (tower, outs), and to
    another vehicle only when that vehicle is its target. A packet from a GCS-side
    link goes to the links whose systems match its target_system (vehicle links own
    their configured sysid from the start, and learn any sysid they carry);
    target_system 0 is a broadcast to every other link. Packets are forwarded as the
    raw bytes received (sysid, compid, seq, signature untouched); only messages that
    are translated are re-encoded, with the same sysid, compid and seq (bridge.codec).

The rooms, and what a packet meets on its way
    vehicle LOCAL_POSITION_NED / ATTITUDE_QUATERNION -> clock_desk (the vehicle's clock
    into timeline) -> pairing (transforms) -> clock_desk.place (onto the one timeline, or
    held back) -> frame_tree (buffer, stream) -> follower (what the rover gets). SYSTEM_TIME
    and TIMESYNC -> clock_desk. Tower goals -> goals.GoalDesk.try_goal (one hop: lookup,
    translate, send). Telemetry to the tower is mapped world -> tower here (a telemetry
    message without a transform is dropped and counted, never sent in the wrong frame).
Lockstep (--lockstep, bridge.lockstep_desk)
    The world's TOWERLINK_LOCKSTEP TICKs (never routed on) make a barrier once they came on
    every vehicle link; goal retries and the follower's checks then run at barriers on sim
    time instead of every wall tick, the bridge ACKs, and relays the TICK to the tower.
"""
from __future__ import annotations

import math
import selectors
import sys
import time

from common.mavlink.dialect import towerlink as tl
from common.frames import TransformException
from bridge import translate
from bridge.clock_desk import ClockDesk
from bridge.codec import Codec, bridge_status_message, command_message, statustext_message
from common.tf2_ros.wire import transform_from_message, transform_message
from common.mavlink.mavstr import mav_str
from bridge.config import BridgeConfig, VehicleRecord
from bridge.follower import Follower
from bridge.frame_tree import FrameTree
from bridge.goals import GoalDesk, PendingGoal
from bridge.telemetry import MSG_LOCAL_POSITION_NED, MSG_POSITION_TARGET_LOCAL_NED, TELEMETRY_IN, TelemetryDesk
from bridge.links import Link, Packet
from bridge.node_desk import NodeDesk
from bridge.lockstep_desk import LockstepDesk
from bridge.node_lockstep import NodeLockstep
from bridge.origins import OriginDesk, origin_frame
from bridge.pairing import VehicleFrames
from bridge.timeline import Timeline
from bridge.trust import StaticTrust
from common.mavlink.signing import SignatureCheck

MSG_SET_POSITION_TARGET_LOCAL_NED = 84
MSG_TL_TRANSFORM = 43000
MSG_TL_STATIC = 43001
MSG_TL_TARGET = 43002
MSG_TL_LOCKSTEP = 43005

TICK = 0.01                     # wall s between upkeep passes
VEHICLE_BATCH = 32              # vehicle datagrams handled before the GCS links are read again
VEHICLE_BATCHES = 8             # batches per vehicle link per select (256 datagrams, as before)
STATIC_PERIOD = 1.0             # wall s between republishing static transforms
STATUS_PERIOD = 1.0
TIMESYNC_PERIOD = 1.0           # wall s between TIMESYNC probes of each vehicle link
#: vehicle -> tower messages mapped world -> tower
TO_TOWER = {MSG_LOCAL_POSITION_NED: translate.local_position,
            MSG_POSITION_TARGET_LOCAL_NED: translate.position_target}


class Bridge:
    def __init__(self, cfg: BridgeConfig, clock=time.monotonic, log=None) -> None:
        self.cfg = cfg
        self.clock = clock
        self._log = log
        self.t0 = clock()
        self.tree = FrameTree(cfg.statics, cfg.world_frame, cfg.cache_time, cfg.tf_rate,
                              cfg.max_transform_age)
        self.buffer = self.tree.buffer
        self.tower = Link("tower", cfg.tower, clock)
        if cfg.route_only and cfg.follow:
            cfg.follow = False          # the nodes follow; the bridge only routes
        self.outs = [Link(f"out{i}", url, clock) for i, url in enumerate(cfg.outs)]
        self.node_links = [Link("nodes", cfg.nodes, clock)] if cfg.nodes else []
        self.outs += self.node_links
        self.gcs_links = [self.tower, *self.outs]
        self._gcs_set = set(self.gcs_links)
        self._gcs_udp = [link for link in self.gcs_links if link.kind in ("udpin", "udpout")]
        self.vehicles: dict[int, VehicleRecord] = {}
        first = (cfg.vehicles[0][0] if cfg.vehicles else "drone" if cfg.drone else None)
        self.origins = OriginDesk(cfg.world_frame, cfg.world_origin, first)   # world: its origin
        for name, url, sysid in (cfg.vehicles or (("drone", cfg.drone, cfg.drone_sysid),
                                                  ("rover", cfg.rover, cfg.rover_sysid))):
            if url:
                link = Link(name, url, clock)
                link.sysids.add(sysid)
                self.vehicles[sysid] = VehicleRecord(name, sysid, link, VehicleFrames(name, origin_frame(name)))
                if not cfg.route_only:
                    self.tree.add_vehicle(name)
        self.links = [*self.gcs_links, *(v.link for v in self.vehicles.values())]
        self.codec = Codec(cfg.sysid, cfg.compid, cfg.signing_key)
        self.trust = StaticTrust(frozenset(cfg.trust_sysids), cfg.allow_redefine)
        if cfg.signing_key:
            checked = [self.tower, *self.node_links]
            if cfg.vehicle_signing:         # what it translates from them goes out signed: check them
                checked += [v.link for v in self.vehicles.values()]
            for link in checked:
                check = SignatureCheck(cfg.signing_key)
                link.verify = lambda p, check=check: check.check(p.raw, p.sysid, p.compid)
        # the speedup only extrapolates a clock for log lines; `max` (inf) has no such rate
        self.timeline = Timeline(speedup=cfg.speedup if math.isfinite(cfg.speedup) else 1.0,
                                 grace=cfg.time_grace)
        # what decides behaviour (goal retries, follow checks and retries, stream re-requests)
        # runs on this clock: the world's lockstep barrier (sim s) with --lockstep, else wall
        # nodes in lockstep answer the bridge, which answers the world once they settled
        self.node_lockstep = NodeLockstep(self.node_links[0], self.codec.pack_own, cfg.lockstep_nodes, self.log,
                                          clock) if cfg.lockstep and self.node_links else None
        self.lockstep = LockstepDesk(self.vehicles, self.codec.pack_own, self.tower.send,
                                     self.on_sim_tick, self.log, clock,
                                     hold=self.node_lockstep.hold if self.node_lockstep else None) \
            if cfg.lockstep else None
        self.behaviour_clock = (lambda: self.lockstep.sim_now) if self.lockstep else clock
        self.clocks = ClockDesk(self.timeline, self.command, lambda v, m: v.link.send(self.codec.pack_own(m)),
                                self.log, self.warn_once, clock)
        self.goals = GoalDesk(self.tree, self.codec, self.to_vehicle, self.tower.stats,
                              self.timeline.world_clock, self.behaviour_clock, self.log, self.statustext,
                              cfg.world_frame, self.vehicle_frame)
        # one follower per (drone, rover) pair; only the first reports TOWERLINK_FOLLOW_STATUS
        # (the message names no vehicle), the others log and steer
        self.followers: dict[int, tuple[Follower, int]] = {}
        # a family (--vehicle) follows exactly its pairs, maybe none; the lab its drone and rover
        for k, (d, r) in enumerate(cfg.pairs if cfg.vehicles else [(cfg.drone_sysid, cfg.rover_sysid)]):
            if d in self.vehicles:
                self.followers[d] = (Follower(cfg, self.buffer, self.behaviour_clock, self.log, self.warn_once,
                                              self.vehicles[d].name, status=k == 0), r)
        self.follower = next(iter(self.followers.values()))[0] if self.followers else \
            Follower(cfg, self.buffer, self.behaviour_clock, self.log, self.warn_once)
        self.telemetry = TelemetryDesk(self)
        self.node_desk = NodeDesk(self)
        self.tower_drops = 0
        self._next = {"hb": 0.0, "timesync": 0.0, "static": 0.0, "status": 0.0}
        self._warned: dict[str, float] = {}
        self.running = True
        self.sel = LinkSelector()

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

    def vehicle_frame(self, sysid: int) -> str:
        """The frame vehicle `sysid`'s local NED is in: <name>_origin (world for others)."""
        v = self.vehicles.get(sysid)
        return origin_frame(v.name) if v is not None else self.cfg.world_frame

    # ------------------------------------------------------------------ sending
    def send_own_to_gcs(self, msg) -> None:
        """One of the bridge's own messages (the transform stream, status, texts) to every GCS
        link, queued behind the telemetry (flushed after each batch and each upkeep pass)."""
        data = self.codec.pack_own(msg)
        for link in self.gcs_links:
            link.queue(data)

    def statustext(self, text: str, severity: int = tl.MAV_SEVERITY_WARNING) -> None:
        self.send_own_to_gcs(statustext_message(text, severity))

    def to_vehicle(self, target: int, data: bytes, exclude: Link | None = None) -> bool:
        """Send to the vehicle links that carry `target` (0: all); True if any did."""
        sent = False
        for v in self.vehicles.values():
            if v.link is not exclude and (target == 0 or target in v.link.sysids):
                v.link.send(data)
                sent = True
        return sent

    def command(self, v: VehicleRecord, command: int, *params) -> None:
        v.link.send(self.codec.pack_own(command_message(v.sysid, command, *params)))

    def send_out(self, out: list[tuple], rover: VehicleRecord | None = None) -> None:
        """Send what a room decided: ("rover", msg) to `rover` (default: the lab's) or
        ("gcs", msg), packed as the bridge."""
        if rover is None:
            rover = self.vehicles.get(self.cfg.rover_sysid)
        for dest, msg in out:
            if dest == "gcs":
                self.send_own_to_gcs(msg)
            elif rover is not None:
                rover.link.send(self.codec.pack_own(msg))

    # ------------------------------------------------------------------ routing
    def route_from_gcs(self, link: Link, pkt: Packet) -> None:
        t = pkt.target_system
        if t == self.cfg.sysid:
            return
        sent = False
        for other in self.links:
            if other is not link and (t == 0 or t in other.sysids):
                other.send(pkt.raw)
                sent = True
        if t and not sent:
            link.stats.unroutable += 1

    def route_from_vehicle(self, v: VehicleRecord, pkt: Packet, to_tower: bytes | None) -> None:
        t = pkt.target_system
        if t == self.cfg.sysid:
            return
        if to_tower is not None:
            self.tower.queue(to_tower)      # coalesced, flushed after each batch (run_once)
        for o in self.outs:
            o.queue(pkt.raw)
        if t:
            for other in self.vehicles.values():
                if other is not v and t in other.link.sysids:
                    other.link.send(pkt.raw)

    # ------------------------------------------------------------------ packets in
    def on_packet(self, link: Link, pkt: Packet) -> None:
        if link in self.gcs_links:
            self.on_gcs_packet(link, pkt)
            return
        if pkt.refused is not None:             # --vehicle-signing, and this one did not pass
            return
        v = self.vehicles.get(pkt.sysid)
        if v is None or v.link is not link:
            # a system behind a vehicle link that is not the configured one (e.g. a camera)
            for cand in self.vehicles.values():
                if cand.link is link:
                    self.route_from_vehicle(cand, pkt, pkt.raw)
                    return
            return
        self.on_vehicle_packet(v, pkt)

    def _decode(self, link: Link, pkt: Packet):
        msg = self.codec.decode(pkt.raw)
        if msg is None:
            link.stats.malformed += 1
        return msg

    def on_gcs_packet(self, link: Link, pkt: Packet) -> None:
        if pkt.refused is not None:             # signing on, and this one did not pass
            if pkt.msgid == MSG_TL_STATIC:
                self.add_static(link, pkt, self._decode(link, pkt))
            elif pkt.msgid == MSG_TL_TRANSFORM:
                self.node_desk.on_transform(link, pkt, self._decode(link, pkt))
            return
        link.sysids.add(pkt.sysid)
        mid = pkt.msgid
        if mid == MSG_SET_POSITION_TARGET_LOCAL_NED and link is self.tower:
            msg = self._decode(link, pkt)
            if msg is None:
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES and self.cfg.route_only:
                self.node_desk.tower_goal(link, pkt)
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES:
                self.goals.submit(PendingGoal("spt", msg, (pkt.sysid, pkt.compid, pkt.seq, pkt.v2),
                                              self.cfg.tower_frame, msg.target_system, self.clock(),
                                              stamp=self.goal_stamp(msg)))
                return
        elif mid == MSG_TL_TARGET:
            msg = self._decode(link, pkt)
            if msg is not None:
                self.goals.submit(PendingGoal("named", msg, (pkt.sysid, pkt.compid, pkt.seq, True),
                                              mav_str(msg.frame_id), msg.target_system, self.clock(),
                                              stamp=self.goal_stamp(msg)))
            return
        elif mid == MSG_TL_STATIC:
            msg = self._decode(link, pkt)
            if msg is not None and msg.target_system in (0, self.cfg.sysid):
                self.add_static(link, pkt, msg)
            return
        elif mid == MSG_TL_TRANSFORM:
            # a node's frame: judged, stored and republished on our stream; never echoed to vehicles
            self.node_desk.on_transform(link, pkt, self._decode(link, pkt))
            return
        elif mid == MSG_TL_LOCKSTEP and link in self.node_links:
            msg = self._decode(link, pkt)       # a node's: the bridge's own participant, never routed
            if msg is not None and self.node_lockstep is not None:
                self.node_lockstep.on_message(pkt.sysid, pkt.compid, msg)
            return
        elif mid == MSG_TL_LOCKSTEP and link is self.tower and self.lockstep is not None:
            msg = self._decode(link, pkt)
            if msg is not None:
                self.lockstep.on_tower(msg)     # and on to the world, in order after its goals
        self.route_from_gcs(link, pkt)

    def goal_stamp(self, msg) -> float | None:
        """A tower goal's time_boot_ms (the target vehicle's clock) on the one timeline, or None."""
        ms = getattr(msg, "time_boot_ms", 0)
        if not isinstance(ms, int) or ms <= 0:
            return None
        v = self.vehicles.get(msg.target_system)
        t = self.timeline.to_ref(v.name, ms / 1000.0) if v is not None else None
        return ms / 1000.0 if t is None else t

    def on_vehicle_packet(self, v: VehicleRecord, pkt: Packet) -> None:
        if pkt.msgid == MSG_TL_LOCKSTEP:        # the world's TICK: ours, never routed raw
            msg = self._decode(v.link, pkt)
            if msg is not None and self.lockstep is not None:
                self.lockstep.on_vehicle(v, msg)
            return
        to_tower = pkt.raw
        if pkt.msgid in TELEMETRY_IN:
            msg = self.codec.decode(pkt.raw)
            if msg is None:
                return
            if pkt.msgid in TO_TOWER and (pkt.msgid == MSG_LOCAL_POSITION_NED or
                                          msg.coordinate_frame in translate.TRANSLATED_FRAMES):
                to_tower = self.translate_to_tower(msg, pkt, TO_TOWER[pkt.msgid], origin_frame(v.name))
            if not self.telemetry.on_message(v, pkt.msgid, pkt.compid, msg):
                return              # the answer to our own probe: not forwarded
        self.route_from_vehicle(v, pkt, to_tower)

    def translate_to_tower(self, msg, pkt: Packet, fn, source: str) -> bytes | None:
        """`msg` (in the vehicle's `source` = <name>_origin frame) mapped to tower and packed
        as its sender, or None (dropped, counted)."""
        if not self.tower.connected:
            return None
        try:
            T = self.tree.lookup(self.cfg.tower_frame, source)
        except TransformException as exc:
            self.tower_drops += 1
            self.warn_once("to-tower", f"telemetry to the tower dropped: no {source} -> "
                                       f"{self.cfg.tower_frame} transform ({exc})")
            return None
        self.tower.stats.translated += 1
        return self.codec.pack_as(fn(msg, T.transform), (pkt.sysid, pkt.compid, pkt.seq, pkt.v2))

    # ------------------------------------------------------------------ frames
    def add_static(self, link: Link, pkt: Packet, msg) -> None:
        """TOWERLINK_STATIC_TRANSFORM: added and published, or refused (bridge.trust), answered."""
        try:
            ts = transform_from_message(msg)[0] if msg is not None else None
            why = self.trust.verdict(pkt.sysid, ts.child_frame_id if ts else "", self.tree.owned,
                                     self.tree.authority(ts.child_frame_id) if ts else None, pkt.refused)
            if why is None and ts is not None:
                why = self.node_desk.frames.claimed(ts.child_frame_id)     # a node's frame stays the node's
            if why is None:
                ts = self.tree.add_static(ts, f"static-transform:{pkt.sysid}")
        except (TransformException, ValueError) as exc:
            why = str(exc)
        if why is not None:
            link.stats.refused += 1
            self.log(f"static transform from sysid {pkt.sysid} refused: {why}")
            text = statustext_message(f"static tf refused: {why}", tl.MAV_SEVERITY_ERROR)
            if pkt.addr is not None and pkt.addr not in link.peers:
                link.reply(pkt.addr, self.codec.pack_own(text))    # not a peer: answer it alone
            self.send_own_to_gcs(text)
            return
        self.log(f"static transform {ts.frame_id} -> {ts.child_frame_id} added by sysid {pkt.sysid}")
        self.statustext(f"static tf {ts.frame_id}->{ts.child_frame_id} added", tl.MAV_SEVERITY_INFO)
        self.send_own_to_gcs(transform_message(ts, static=True))

    # ------------------------------------------------------------------ periodic
    def _due(self, what: str, now: float, period: float) -> bool:
        if now >= self._next[what]:
            self._next[what] = now + period
            return True
        return False

    def sim_checks(self, rover_clock: tuple) -> None:
        """Goal retries and the follower's checks: every wall tick, or with --lockstep at
        every barrier (the world's sim time), so they happen at the same sim time every run."""
        self.goals.retry()
        if self.cfg.follow:
            for follower, rsys in self.followers.values():
                rover = self.vehicles.get(rsys)
                if rover is not None:
                    self.send_out(follower.check(rover, *rover_clock(rover)), rover)

    def on_sim_tick(self, t: float) -> None:
        """The lockstep barrier reached sim time t (s): the sim-time upkeep, before the ACK."""
        self.telemetry.ask_origins(t)
        # the rover's clock is live by construction (the world ticked): stale is judged on stamps
        self.sim_checks(lambda rover: (self.timeline.newest(rover.name)[0], t))

    def tick(self) -> None:
        now = self.clock()
        for link in self.links:
            link.poll()
        self.telemetry.release_held()
        if self.lockstep is None:       # with lockstep at barriers (on_sim_tick): a sim time the data fixes
            self.telemetry.ask_origins(now)
        if self.lockstep is None:
            self.sim_checks(lambda rover: self.timeline.newest(rover.name))
        else:
            self.lockstep.upkeep(now)
            if self.node_lockstep is not None:
                self.node_lockstep.upkeep()
        bnow = self.behaviour_clock()
        if self._due("hb", now, 1.0):
            data = self.codec.pack_own(tl.MAVLink_heartbeat_message(
                tl.MAV_TYPE_ONBOARD_CONTROLLER, tl.MAV_AUTOPILOT_INVALID, 0, 0, tl.MAV_STATE_ACTIVE, 3))
            for v in self.vehicles.values():
                v.link.send(data)
                if v.last_heartbeat_wall is not None and (bnow - v.last_att_wall > 2.0 or bnow - v.last_pos_wall > 2.0):
                    self.telemetry.request_streams(v)
        if self._due("timesync", now, TIMESYNC_PERIOD):
            self.clocks.probe(self.vehicles, now)
        if self._due("static", now, STATIC_PERIOD):
            for ts in self.tree.static_transforms():
                self.send_own_to_gcs(transform_message(ts, static=True))
        if self._due("status", now, STATUS_PERIOD):
            usec = int((now - self.t0) * 1e6)
            for link in self.links:
                self.send_own_to_gcs(bridge_status_message(usec, link.name, link.stats, link.malformed))
        self._flush_gcs()

    # ------------------------------------------------------------------ loop
    def run_once(self, timeout: float) -> None:
        """One select: the GCS links' packets first, then each vehicle link's in batches of
        VEHICLE_BATCH with the GCS links read again between batches, so a tower goal never
        waits behind a burst of telemetry (1,000 vehicles send 6,600 datagrams every 100 ms)."""
        ready = self.sel.select(self.links, timeout)
        later = []
        for key, _ev in ready:
            if key.data in self._gcs_set:
                self._handle(key.data, key.data.on_readable(key.fileobj))
            else:
                later.append(key)
        since = 0                       # vehicle packets handled since the GCS links were last served
        for key in later:
            link = key.data
            for _ in range(VEHICLE_BATCHES):
                pkts = link.on_readable(key.fileobj, VEHICLE_BATCH)
                self._handle(link, pkts)
                since += len(pkts)
                if since >= VEHICLE_BATCH:     # counted over links: 100 links with a few each too
                    since = 0
                    self._flush_gcs()
                    self._service_gcs()
                if link.drained:
                    break
        self._flush_gcs()

    def _flush_gcs(self) -> None:
        for link in self.gcs_links:
            link.flush()

    def _service_gcs(self) -> None:
        """Read whatever waits on the UDP GCS links now (non-blocking; one syscall per idle
        socket; TCP ones wait for the next select, their sockets may be mid-connect)."""
        for link in self._gcs_udp:
            for s in link.fileobjs():
                pkts = link.on_readable(s)
                if pkts:
                    self._handle(link, pkts)

    def _handle(self, link: Link, pkts) -> None:
        for pkt in pkts:
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
        return summary(self)

    def close(self) -> None:
        if self.lockstep is not None:
            self.lockstep.leave()
        for link in self.links:
            link.close()
        self.sel.close()


class LinkSelector:
    """selectors over the links' sockets, which change (tcp reconnects, tcpin clients)."""

    def __init__(self) -> None:
        self.sel = selectors.DefaultSelector()
        self._registered: dict = {}

    def select(self, links, timeout: float):
        want = {s: link for link in links for s in link.fileobjs()}
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
        return self.sel.select(timeout)

    def close(self) -> None:
        self.sel.close()


def summary(b: Bridge) -> str:
    """The bridge's end-of-run counters, one line per link and vehicle."""
    parts = []
    for link in b.links:
        st = link.stats
        parts.append(f"{link.name}: rx {st.rx_packets} tx {st.tx_packets} malformed {link.malformed} "
                     f"unroutable {st.unroutable} translated {st.translated} deferred {st.deferred} "
                     f"refused {st.refused} unsigned {st.unsigned} bad signature {st.bad_signature}")
    for v in b.vehicles.values():
        p = v.probe
        rtt = "-" if p.rtt is None else f"{p.rtt * 1e3:.2f} ms (min {p.rtt_min * 1e3:.2f} ms)"
        parts.append(f"{v.name}: timeline {b.timeline.basis(v.name)}; TIMESYNC round trip {rtt}; "
                     f"samples held back {b.timeline.held(v.name)}")
    nf = b.node_desk.frames
    if nf.owners or nf.refused:
        parts.append(f"node frames: {', '.join(f'{c} by {o}' for c, o in sorted(nf.owners.items())) or '-'}; "
                     f"refused {sum(nf.refused.values())}")
    ticks = " ".join(f"{b.vehicles[d].name}:{f.ticks}" for d, (f, _r) in b.followers.items())
    parts.append(f"follow ticks {ticks or 0}; decode errors {b.codec.decode_errors}; "
                 f"tower telemetry dropped (no transform) {b.tower_drops}")
    if b.lockstep is not None:
        parts.append(f"lockstep: {b.lockstep.barriers} barriers, last at {b.lockstep.sim_now:.3f} s sim; "
                     f"tower {'joined' if b.lockstep.tower_joined else 'not joined'}; "
                     f"TICKs sent to the tower again {b.lockstep.tick_resends}; "
                     f"the world's TICKs answered again {b.lockstep.tick_resends_seen}")
    if b.node_lockstep is not None:
        parts.append(b.node_lockstep.summary())
    return "\n".join(parts)
