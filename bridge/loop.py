"""The bridge: one select loop that routes packets and hands each to the room that owns it.

:class:`Bridge` builds the rooms and wires them (collaborators passed in constructors):
bridge.socket_loop (the select loop), bridge.router (where packets go, the bridge's own
sends), bridge.gcs_side and bridge.vehicle_side (what each side's packets mean to the bridge),
bridge.upkeep (what runs on a clock), bridge.status (the end-of-run counters).

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
    translate, send). Telemetry to the tower is mapped <name>_origin -> tower (vehicle_side:
    a telemetry message without a transform is dropped and counted, never sent in the wrong
    frame).
Lockstep (--lockstep, bridge.lockstep_desk)
    The world's TOWERLINK_LOCKSTEP TICKs (never routed on) make a barrier once they came on
    every vehicle link; goal retries and the follower's checks then run at barriers on sim
    time instead of every wall tick, the bridge ACKs, and relays the TICK to the tower. When
    the world is pipelined, each frame is handled whole, links in a fixed order, once the
    tower acted on the barrier before it (bridge.frame_hold).
"""
from __future__ import annotations

import math
import time

from common.mavlink.signing import SignatureCheck
from bridge.clock_desk import ClockDesk
from bridge.codec import Codec
from bridge.config import BridgeConfig, VehicleRecord
from bridge.follower import Follower
from bridge.frame_tree import FrameTree
from bridge.gcs_side import GcsSide
from bridge.goals import GoalDesk
from bridge.links import Link
from bridge.lockstep_desk import LockstepDesk
from bridge.node_lockstep import NodeLockstep
from bridge.log import BridgeLog
from bridge.node_desk import NodeDesk
from bridge.origins import OriginDesk, origin_frame
from bridge.pairing import VehicleFrames
from bridge.router import Router
from bridge.socket_loop import PacketLoop
from bridge.static_desk import StaticDesk
from bridge.status import summary
from bridge.telemetry import TelemetryDesk
from bridge.timeline import Timeline
from bridge.trust import StaticTrust
from bridge.upkeep import SimChecks, Upkeep
from bridge.vehicle_side import VehicleSide


class Bridge:
    """The bridge, built from `cfg`: its links open, its rooms wired; run() routes."""

    def __init__(self, cfg: BridgeConfig, clock=time.monotonic, log=None) -> None:
        self.cfg = cfg
        self.clock = clock
        self.t0 = clock()
        self._log = BridgeLog(clock, self.t0, log, cfg.quiet)
        self.log, self.warn_once = self._log.log, self._log.warn_once
        self.tree = FrameTree(cfg.statics, cfg.world_frame, cfg.cache_time, cfg.tf_rate,
                              cfg.max_transform_age)
        self.buffer = self.tree.buffer
        if cfg.route_only and cfg.follow:
            cfg.follow = False          # the nodes follow; the bridge only routes
        self._links(cfg, clock)
        self.codec = Codec(cfg.sysid, cfg.compid, cfg.signing_key)
        self.trust = StaticTrust(frozenset(cfg.trust_sysids), cfg.allow_redefine)
        if cfg.signing_key:
            checked = [self.tower, *self.node_links]
            if cfg.vehicle_signing:         # what it translates from them goes out signed: check them
                checked += [v.link for v in self.vehicles.values()]
            for link in checked:
                check = SignatureCheck(cfg.signing_key)
                link.verify = lambda p, check=check: check.check(p.raw, p.sysid, p.compid)
        self.router = Router(self.tower, self.outs, self.vehicles, self.codec, cfg.sysid, cfg.rover_sysid)
        self.links = self.router.links
        # the speedup only extrapolates a clock for log lines; `max` (inf) has no such rate
        self.timeline = Timeline(speedup=cfg.speedup if math.isfinite(cfg.speedup) else 1.0,
                                 grace=cfg.time_grace)
        # what decides behaviour (goal retries, follow checks and retries, stream re-requests)
        # runs on this clock: the world's lockstep barrier (sim s) with --lockstep, else wall
        # nodes in lockstep (--nodes) answer the bridge, which answers the world once they settled
        nodes = NodeLockstep(self.node_links[0], self.codec.pack_own, cfg.lockstep_nodes, self.log, clock) \
            if cfg.lockstep and self.node_links else None
        self.lockstep = LockstepDesk(self.vehicles, self.codec.pack_own, self.tower.queue,
                                     self._at_barrier, self.log, clock, nodes=nodes,
                                     on_free=self._links_free) if cfg.lockstep else None
        self.behaviour_clock = (lambda: self.lockstep.sim_now) if self.lockstep else clock
        self.clocks = ClockDesk(self.timeline, self.router.command, self.router.send_own,
                                self.log, self.warn_once, clock)
        self.goals = GoalDesk(self.tree, self.codec, self.router.to_vehicle, self.tower.stats,
                              self.timeline.world_clock, self.behaviour_clock, self.log, self.router.statustext,
                              cfg.world_frame, self.vehicle_frame)
        self._followers(cfg)
        self.telemetry = TelemetryDesk(cfg, self.vehicles, self.clocks, self.timeline, self.tree, self.origins,
                                       self.followers, self.router, self._log, self.behaviour_clock, clock)
        self.node_desk = NodeDesk(self.trust, self.tree, self.node_links, self.codec, self.router, self._log)
        statics = StaticDesk(self.trust, self.tree, self.node_desk.frames, self.codec, self.router, self._log)
        self.gcs_side = GcsSide(cfg, self.tower, self.codec, self.router, self.goals, statics, self.node_desk,
                                self.lockstep, self.timeline, self.vehicles, clock)
        self.vehicle_side = VehicleSide(self.tower, cfg.tower_frame, self.vehicles, self.codec, self.tree,
                                        self.telemetry, self.lockstep, self.router, self._log)
        self.sim_checks = SimChecks(self.goals, self.followers, self.vehicles, self.router, self.timeline,
                                    cfg.follow)
        self.upkeep = Upkeep(self.links, self.vehicles, self.router, self.codec, self.telemetry, self.clocks,
                             self.tree, self.sim_checks, self.lockstep, self.behaviour_clock, clock, self.t0)
        self.loop = PacketLoop(self.router.gcs_links, [v.link for v in self.vehicles.values()],
                               self.gcs_side.on_packet, self.vehicle_side.on_packet, self.upkeep.tick,
                               clock, self.warn_once, self.lockstep.gcs_due if self.lockstep else None)

    def _links(self, cfg: BridgeConfig, clock) -> None:
        """The tower, the outs (--out, then --nodes) and one link per vehicle, each vehicle
        owning its configured sysid from the start."""
        self.tower = Link("tower", cfg.tower, clock)
        self.outs = [Link(f"out{i}", url, clock) for i, url in enumerate(cfg.outs)]
        self.node_links = [Link("nodes", cfg.nodes, clock)] if cfg.nodes else []
        self.outs += self.node_links
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

    def _followers(self, cfg: BridgeConfig) -> None:
        """One follower per (drone, rover) pair; only the first reports TOWERLINK_FOLLOW_STATUS
        (the message names no vehicle), the others log and steer."""
        self.followers: dict[int, tuple[Follower, int]] = {}
        # a family (--vehicle) follows exactly its pairs, maybe none; the lab its drone and rover
        for k, (d, r) in enumerate(cfg.pairs if cfg.vehicles else [(cfg.drone_sysid, cfg.rover_sysid)]):
            if d in self.vehicles:
                self.followers[d] = (Follower(cfg, self.buffer, self.behaviour_clock, self.log, self.warn_once,
                                              self.vehicles[d].name, status=k == 0), r)
        self.follower = next(iter(self.followers.values()))[0] if self.followers else \
            Follower(cfg, self.buffer, self.behaviour_clock, self.log, self.warn_once)

    def _at_barrier(self, t: float) -> None:
        # the lockstep desk exists before the sim checks it drives (they read its clock)
        self.telemetry.ask_origins(t)       # on sim time: the origins come at a TICK the data fixes
        self.sim_checks.at_barrier(t)

    def _links_free(self) -> None:
        # pipelined lockstep: a barrier is done; the next frame's packets may go on
        self.vehicle_side.release_held()

    def vehicle_frame(self, sysid: int) -> str:
        """The frame vehicle `sysid`'s local NED is in: <name>_origin (world for others)."""
        v = self.vehicles.get(sysid)
        return origin_frame(v.name) if v is not None else self.cfg.world_frame

    # ------------------------------------------------------------------ running
    def run_once(self, timeout: float) -> None:
        """One select and the packets it found (bridge.socket_loop)."""
        self.loop.run_once(timeout)

    def run(self, duration: float | None = None) -> None:
        """Route until stop() (or `duration` wall s)."""
        self.loop.run(duration)

    def stop(self, *_a) -> None:
        """Stop run() (also a signal handler)."""
        self.loop.stop()

    def summary(self) -> str:
        """The end-of-run counters (bridge.status)."""
        return summary(self.links, self.vehicles, self.timeline, self.node_desk.frames, self.followers,
                       self.codec.decode_errors, self.vehicle_side.tower_drops, self.lockstep,
                       self.vehicle_side.hold.held if self.vehicle_side.hold is not None else 0)

    def close(self) -> None:
        """LEAVE the lockstep (if in it), close every link and the selector."""
        if self.lockstep is not None:
            self.lockstep.leave()
        for link in self.links:
            link.close()
        self.loop.close()
