"""Packets from the vehicle links: what the bridge reads of them, and what the tower gets.

* TOWERLINK_LOCKSTEP (the world's TICK) is the lockstep desk's, never routed on.
* Telemetry the bridge reads (bridge.telemetry.TELEMETRY_IN) is decoded and handed to the
  telemetry desk (clocks, pairing, frame tree, follower); the answer to the bridge's own
  TIMESYNC probe stops there.
* LOCAL_POSITION_NED, and POSITION_TARGET_LOCAL_NED in a translated frame, reach the tower
  mapped from the vehicle's <name>_origin into the tower frame, re-packed as the vehicle sent
  them (sysid, compid, seq, version); without that transform the tower gets nothing (dropped
  and counted, never sent in the wrong frame). The outs and other vehicles get the raw bytes.
* A system behind a vehicle link other than the configured vehicle (a camera, a companion)
  is routed as that link's vehicle's traffic, undecoded.
* In a pipelined lockstep the packets wait (bridge.frame_hold) and are handled a whole frame
  at a time, links in a fixed order, once the bridge is done with the barrier before it.
"""
from __future__ import annotations

from common.frames import TransformException
from common.mavlink import lockstep as lockstep_wire
from common.mavlink.frame_parser import Packet
from bridge import translate
from bridge.codec import Codec
from bridge.config import VehicleRecord
from bridge.frame_hold import FrameHold
from bridge.frame_tree import FrameTree
from bridge.links import Link, handle_guarded
from bridge.lockstep_desk import LockstepDesk
from bridge.log import BridgeLog
from bridge.origins import origin_frame
from bridge.router import Router
from bridge.telemetry import MSG_LOCAL_POSITION_NED, MSG_POSITION_TARGET_LOCAL_NED, TELEMETRY_IN, TelemetryDesk

MSG_TL_LOCKSTEP = 43005
#: vehicle -> tower messages mapped <name>_origin -> tower
TO_TOWER = {MSG_LOCAL_POSITION_NED: translate.local_position,
            MSG_POSITION_TARGET_LOCAL_NED: translate.position_target}


class VehicleSide:
    """What a vehicle link's packet means to the bridge (see the module docstring)."""

    def __init__(self, tower: Link, tower_frame: str, vehicles: dict[int, VehicleRecord], codec: Codec,
                 tree: FrameTree, telemetry: TelemetryDesk, lockstep: LockstepDesk | None, router: Router,
                 log: BridgeLog) -> None:
        self.tower = tower
        self.tower_frame = tower_frame
        self.vehicles = vehicles            # sysid -> VehicleRecord
        self._owner = {v.link: v for v in vehicles.values()}     # each vehicle has a link of its own
        self.codec = codec
        self.tree = tree
        self.telemetry = telemetry
        self.lockstep = lockstep
        self.router = router
        self.warn_once = log.warn_once
        self.tower_drops = 0                # telemetry not sent to the tower: no transform
        # pipelined lockstep: a link's next frame waits until the bridge is done with this one
        self.hold = FrameHold([v.link for v in vehicles.values()], self._handle_held, self._tick_time,
                              lambda: lockstep.lag > 0, lockstep.frame_ready) if lockstep is not None else None

    def on_packet(self, link: Link, pkt: Packet) -> None:
        """One packet from vehicle `link`: held for a barrier not yet done (bridge.frame_hold), or handled."""
        if self.hold is not None and self.hold.take(link, pkt):
            return
        self.handle(link, pkt)

    def release_held(self) -> None:
        """What the links held, handled in order as far as their barriers are done (the lockstep
        desk calls this when one may be)."""
        self.hold.release()

    def _tick_time(self, pkt: Packet) -> int | None:
        """A TICK's time (us) for the hold, or None."""
        if pkt.msgid != MSG_TL_LOCKSTEP:
            return None
        msg = lockstep_wire.read_checked(pkt.raw)
        return msg.time_usec if msg is not None and msg.kind == lockstep_wire.TICK else None

    def _handle_held(self, link: Link, pkt: Packet) -> None:
        handle_guarded(self.handle, link, pkt, self.warn_once)      # as the loop handles a packet

    def handle(self, link: Link, pkt: Packet) -> None:
        """One packet from vehicle `link`: read if it is the bridge's business, and routed."""
        if pkt.refused is not None:             # --vehicle-signing, and this one did not pass
            return
        v = self.vehicles.get(pkt.sysid)
        if v is None or v.link is not link:
            # a system behind a vehicle link that is not the configured one (e.g. a camera)
            owner = self._owner.get(link)
            if owner is not None:
                self.router.from_vehicle(owner, pkt, pkt.raw)
            return
        mid = pkt.msgid
        if mid == MSG_TL_LOCKSTEP:              # the world's TICK: ours, never routed raw
            msg = lockstep_wire.read_checked(pkt.raw)       # the frame parser checked its CRC
            if msg is None:
                link.stats.malformed += 1
            elif self.lockstep is not None:
                self.lockstep.on_vehicle(v, msg)
            return
        to_tower = pkt.raw
        if mid in TELEMETRY_IN:
            msg = self.codec.decode(pkt.raw)
            if msg is None:
                return
            if mid in TO_TOWER and (mid == MSG_LOCAL_POSITION_NED or
                                    msg.coordinate_frame in translate.TRANSLATED_FRAMES):
                to_tower = self.translate_to_tower(msg, pkt, TO_TOWER[mid], origin_frame(v.name))
            if not self.telemetry.on_message(v, mid, pkt.compid, msg):
                return              # the answer to our own probe: not forwarded
        self.router.from_vehicle(v, pkt, to_tower)

    def translate_to_tower(self, msg, pkt: Packet, fn, source: str) -> bytes | None:
        """`msg` (in the vehicle's `source` = <name>_origin frame) mapped to tower by `fn`
        (bridge.translate) and packed as its sender, or None (dropped, counted)."""
        if not self.tower.connected:
            return None
        try:
            T = self.tree.lookup(self.tower_frame, source)
        except TransformException as exc:
            self.tower_drops += 1
            self.warn_once("to-tower", f"telemetry to the tower dropped: no {source} -> "
                                       f"{self.tower_frame} transform ({exc})")
            return None
        self.tower.stats.translated += 1
        return self.codec.pack_as(fn(msg, T.transform), (pkt.sysid, pkt.compid, pkt.seq, pkt.v2))
