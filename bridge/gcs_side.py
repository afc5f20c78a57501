"""Packets from the GCS-side links (the tower, the outs, the node link): what the bridge
takes for itself, and the rest routed on by target_system (bridge.router).

* SET_POSITION_TARGET_LOCAL_NED from the tower in a translated frame (LOCAL_NED,
  LOCAL_OFFSET_NED: the tower frame): a goal for bridge.goals, or with --route-only the
  raw packet to the nodes (bridge.node_desk); never routed as received.
* TOWERLINK_POSITION_TARGET: a goal in the frame it names.
* TOWERLINK_STATIC_TRANSFORM to the bridge (or to all): bridge.static_desk.
* TOWERLINK_TRANSFORM: a node's frame (bridge.node_desk), never echoed to the vehicles.
* TOWERLINK_LOCKSTEP from the tower (--lockstep): the lockstep desk sees it, and it goes on
  to the world like any broadcast, in order after the tower's goals; pipelined, its ACK then
  lets the next frame's vehicle packets go on (bridge.frame_hold). From a node (the node
  link): the bridge's own participant (bridge.node_lockstep), never routed.

A packet the link's signature check refused is never routed; a static or a node's transform
among them is still read, to be refused and told why.
"""
from __future__ import annotations

from collections.abc import Callable

from common.mavlink.frame_parser import Packet
from common.mavlink.mavstr import mav_str
from bridge import translate
from bridge.codec import Codec
from bridge.config import BridgeConfig, VehicleRecord
from bridge.goals import GoalDesk, PendingGoal
from bridge.links import Link
from bridge.lockstep_desk import LockstepDesk
from bridge.node_desk import NodeDesk
from bridge.router import Router
from bridge.static_desk import StaticDesk
from bridge.timeline import Timeline

MSG_SET_POSITION_TARGET_LOCAL_NED = 84
MSG_TL_TRANSFORM = 43000
MSG_TL_STATIC = 43001
MSG_TL_TARGET = 43002
MSG_TL_LOCKSTEP = 43005


class GcsSide:
    """What a GCS-side link's packet means to the bridge (see the module docstring)."""

    def __init__(self, cfg: BridgeConfig, tower: Link, codec: Codec, router: Router, goals: GoalDesk,
                 statics: StaticDesk, nodes: NodeDesk, lockstep: LockstepDesk | None, timeline: Timeline,
                 vehicles: dict[int, VehicleRecord], clock: Callable[[], float]) -> None:
        self.tower = tower
        self.codec = codec
        self.router = router
        self.goals = goals
        self.statics = statics
        self.nodes = nodes
        self.lockstep = lockstep
        self.timeline = timeline
        self.vehicles = vehicles
        self.own_sysid = cfg.sysid
        self.tower_frame = cfg.tower_frame  # the frame the tower's LOCAL_NED goals are in
        self.route_only = cfg.route_only    # --route-only: the nodes translate the tower's goals
        self.clock = clock                  # () -> wall s

    def decode(self, link: Link, pkt: Packet):
        """The message in `pkt`, or None (counted as malformed on `link`)."""
        msg = self.codec.decode(pkt.raw)
        if msg is None:
            link.stats.malformed += 1
        return msg

    def on_packet(self, link: Link, pkt: Packet) -> None:
        """One packet from GCS-side `link`: taken, or routed on."""
        if pkt.refused is not None:             # signing on, and this one did not pass
            if pkt.msgid == MSG_TL_STATIC:
                self.statics.on_static(link, pkt, self.decode(link, pkt))
            elif pkt.msgid == MSG_TL_TRANSFORM:
                self.nodes.on_transform(link, pkt, self.decode(link, pkt))
            return
        link.sysids.add(pkt.sysid)
        mid = pkt.msgid
        if mid == MSG_SET_POSITION_TARGET_LOCAL_NED and link is self.tower:
            msg = self.decode(link, pkt)
            if msg is None:
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES and self.route_only:
                self.nodes.tower_goal(link, pkt)
                return
            if msg.coordinate_frame in translate.TRANSLATED_FRAMES:
                self.goals.submit(PendingGoal("spt", msg, (pkt.sysid, pkt.compid, pkt.seq, pkt.v2),
                                              self.tower_frame, msg.target_system, self.clock(),
                                              stamp=self.goal_stamp(msg)))
                return
        elif mid == MSG_TL_TARGET:
            msg = self.decode(link, pkt)
            if msg is not None:
                self.goals.submit(PendingGoal("named", msg, (pkt.sysid, pkt.compid, pkt.seq, True),
                                              mav_str(msg.frame_id), msg.target_system, self.clock(),
                                              stamp=self.goal_stamp(msg)))
            return
        elif mid == MSG_TL_STATIC:
            msg = self.decode(link, pkt)
            if msg is not None and msg.target_system in (0, self.own_sysid):
                self.statics.on_static(link, pkt, msg)
            return
        elif mid == MSG_TL_TRANSFORM:
            self.nodes.on_transform(link, pkt, self.decode(link, pkt))
            return
        elif mid == MSG_TL_LOCKSTEP and link in self.nodes.node_links:
            msg = self.decode(link, pkt)        # a node's: the bridge's own participant, never routed
            if msg is not None and self.lockstep is not None:
                self.lockstep.on_node(pkt.sysid, pkt.compid, msg)
            return
        elif mid == MSG_TL_LOCKSTEP and link is self.tower and self.lockstep is not None:
            msg = self.decode(link, pkt)
            if msg is not None:
                self.lockstep.on_tower(msg)     # and on to the world, in order after its goals
                self.router.from_gcs(link, pkt)
                self.lockstep.tower_done()      # pipelined: then the vehicle links may go on
                return
        self.router.from_gcs(link, pkt)

    def goal_stamp(self, msg) -> float | None:
        """A tower goal's time_boot_ms (the target vehicle's clock) on the one timeline, s, or None."""
        ms = getattr(msg, "time_boot_ms", 0)
        if not isinstance(ms, int) or ms <= 0:
            return None
        v = self.vehicles.get(msg.target_system)
        t = self.timeline.to_ref(v.name, ms / 1000.0) if v is not None else None
        return ms / 1000.0 if t is None else t
