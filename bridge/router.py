"""Where a packet goes (mavlink-router / ArduPilot semantics), and the bridge's own sends.

* From a vehicle: to every GCS-side link (the tower gets the bytes the vehicle side chose:
  the packet, its translation into the tower frame, or nothing), and to another vehicle
  only when that vehicle carries its target_system.
* From a GCS-side link: to the links whose systems match its target_system (vehicle links
  own their configured sysid from the start and learn any sysid they carry); target_system
  0 is a broadcast to every other link; one addressed to the bridge itself goes nowhere.
* Packets are forwarded as the raw bytes received (sysid, compid, seq, signature
  untouched). Telemetry and the bridge's own messages to the GCS links are queued
  (bridge.links: coalesced into datagrams) and written by :meth:`Router.flush_gcs`.
* The bridge's own messages are packed as the bridge (codec.pack_own).
"""
from __future__ import annotations

from common.mavlink.dialect import towerlink as tl
from common.mavlink.frame_parser import Packet
from bridge.codec import Codec, command_message, statustext_message
from bridge.config import VehicleRecord
from bridge.links import Link


class Router:
    """The links and where a packet goes between them; the bridge's own sends."""

    def __init__(self, tower: Link, outs: list[Link], vehicles: dict[int, VehicleRecord], codec: Codec,
                 own_sysid: int, rover_sysid: int | None = None) -> None:
        self.tower = tower
        self.outs = outs                    # GCS-side links besides the tower (--out, --nodes)
        self.gcs_links = [tower, *outs]
        self._gcs_set = frozenset(self.gcs_links)
        self.vehicles = vehicles            # sysid -> VehicleRecord
        self.links = [*self.gcs_links, *(v.link for v in vehicles.values())]
        self.codec = codec
        self.own_sysid = own_sysid          # packets to this target are the bridge's, never routed
        self.rover_sysid = rover_sysid      # the lab's rover: send_out's default

    # ------------------------------------------------------------------ routing
    def from_gcs(self, link: Link, pkt: Packet) -> None:
        """`pkt` from GCS-side `link` to the links carrying its target (0: all), raw; an
        unknown target is counted unroutable on `link`."""
        t = pkt.target_system
        if t == self.own_sysid:
            return
        sent = False
        for other in self.links:
            if other is not link and (t == 0 or t in other.sysids):
                if other in self._gcs_set:
                    other.queue(pkt.raw)    # behind the telemetry, in one datagram with it
                else:                       # a datagram of its own: the world's lockstep reads a
                    other.send(pkt.raw)     # TOWERLINK_LOCKSTEP (the tower's ACK) only at its start
                sent = True
        if t and not sent:
            link.stats.unroutable += 1

    def from_vehicle(self, v: VehicleRecord, pkt: Packet, to_tower: bytes | None) -> None:
        """`pkt` from vehicle `v`'s link; `to_tower`: what the tower gets instead of the raw
        bytes (None: nothing)."""
        t = pkt.target_system
        if t == self.own_sysid:
            return
        if to_tower is not None:
            self.tower.queue(to_tower)      # coalesced, flushed after each batch
        for o in self.outs:
            o.queue(pkt.raw)
        if t:
            for other in self.vehicles.values():
                if other is not v and t in other.link.sysids:
                    other.link.send(pkt.raw)

    def flush_gcs(self) -> None:
        """Write what is queued for the GCS-side links."""
        for link in self.gcs_links:
            link.flush()

    # ------------------------------------------------------------------ the bridge's own
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

    def send_own(self, v: VehicleRecord, msg) -> None:
        """One of the bridge's own messages to vehicle `v`."""
        v.link.send(self.codec.pack_own(msg))

    def command(self, v: VehicleRecord, command: int, *params) -> None:
        """COMMAND_LONG `command` to vehicle `v` (its autopilot, compid 1)."""
        self.send_own(v, command_message(v.sysid, command, *params))

    def send_out(self, out: list[tuple], rover: VehicleRecord | None = None) -> None:
        """Send what a room decided: ("rover", msg) to `rover` (default: the lab's) or
        ("gcs", msg), packed as the bridge."""
        if rover is None:
            rover = self.vehicles.get(self.rover_sysid)
        for dest, msg in out:
            if dest == "gcs":
                self.send_own_to_gcs(msg)
            elif rover is not None:
                self.send_own(rover, msg)
