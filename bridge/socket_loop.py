"""The bridge's one select loop: sockets read, packets handed to their side, upkeep on time.

Each select serves the GCS links' packets first, then each vehicle link's in batches of
VEHICLE_BATCH with the GCS links flushed and read again between batches (counted over all
vehicle links), so a tower goal never waits behind a burst of telemetry (1,000 vehicles send
6,600 datagrams every 100 ms). The upkeep tick runs every TICK wall seconds between selects.
With lockstep the GCS links are written at the end of a pass only when it released a barrier
(`gcs_due`): the tower acts at the TICK that comes behind the telemetry anyway, so each barrier
costs the tower and each out one datagram, and the tower one wake-up, instead of one per pass.
A packet whose handling raises is counted as malformed on its link and logged; the loop goes on.
"""
from __future__ import annotations

import selectors
from collections.abc import Callable

from common.mavlink.frame_parser import Packet
from bridge.links import Link, handle_guarded

TICK = 0.01                     # wall s between upkeep passes
VEHICLE_BATCH = 32              # vehicle datagrams handled before the GCS links are read again
VEHICLE_BATCHES = 8             # batches per vehicle link per select (256 datagrams)

OnPacket = Callable[[Link, Packet], None]


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


class PacketLoop:
    """The select loop over every link; packets to `on_gcs` / `on_vehicle` by their link's side."""

    def __init__(self, gcs_links: list[Link], vehicle_links: list[Link], on_gcs: OnPacket, on_vehicle: OnPacket,
                 tick: Callable[[], None], clock: Callable[[], float],
                 warn_once: Callable[[str, str], bool], gcs_due: Callable[[], bool] | None = None) -> None:
        self.gcs_links = gcs_links
        self.links = [*gcs_links, *vehicle_links]
        self._gcs_set = set(gcs_links)
        self._gcs_udp = [link for link in gcs_links if link.kind in ("udpin", "udpout")]
        self.on_gcs = on_gcs                # (link, packet) -> None, for the GCS-side links
        self.on_vehicle = on_vehicle        # (link, packet) -> None, for the vehicle links
        self.tick = tick                    # the upkeep pass
        self.clock = clock                  # () -> wall s
        self.warn_once = warn_once
        # with lockstep: whether a pass must write the GCS links' queues (a barrier was released);
        # else what they queued waits for the barrier's TICK, the next batch or the upkeep
        self.gcs_due = gcs_due
        self.running = True
        self.sel = LinkSelector()

    def run_once(self, timeout: float) -> None:
        """One select (waiting at most `timeout` s), and every packet it found handled."""
        ready = self.sel.select(self.links, timeout)
        later = []
        for key, _ev in ready:
            if key.data in self._gcs_set:
                self._handle(key.data, key.data.on_readable(key.fileobj), self.on_gcs)
            else:
                later.append(key)
        on_vehicle = self.on_vehicle
        since = 0                       # vehicle packets handled since the GCS links were last served
        for key in later:
            link = key.data
            for _ in range(VEHICLE_BATCHES):
                pkts = link.on_readable(key.fileobj, VEHICLE_BATCH)
                self._handle(link, pkts, on_vehicle)
                since += len(pkts)
                if since >= VEHICLE_BATCH:     # counted over links: 100 links with a few each too
                    since = 0
                    self._flush_gcs()
                    self._service_gcs()
                if link.drained:
                    break
        if self.gcs_due is None or self.gcs_due():
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
                    self._handle(link, pkts, self.on_gcs)

    def _handle(self, link: Link, pkts: list[Packet], on: OnPacket) -> None:
        for pkt in pkts:
            handle_guarded(on, link, pkt, self.warn_once)

    def run(self, duration: float | None = None) -> None:
        """Loop until stop() (or `duration` wall s), the upkeep tick every TICK."""
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

    def stop(self) -> None:
        self.running = False

    def close(self) -> None:
        self.sel.close()
