"""A pipelined lockstep's frames, handled whole and in a fixed order, once the bridge is done with the one before.

In a pipelined lockstep (the world's TICKs say lag 1, `sitl --lockstep-pipeline`) the world
sends TICK(t) and steps on at once, so a vehicle link brings the next frame's packets while the
bridge may still be at barrier t: TICK(t) not yet in on another link, or the tower (or the
nodes) not yet done acting on t. Whatever the bridge did with those packets then (the frame
tree, the follower, the telemetry translated for the tower, the tower's goals translated
against that tree) would depend on how fast each process ran; and handled as they come, the
links' packets interleave as the machine delivered them, which orders what the bridge sends
(its transforms of the drone and of the rover). So every vehicle packet waits here, and a
frame -- each link's packets up to its TICK(t') -- is handled once it is complete on every
link and the barrier before it is done (`ready`), link by link in the links' fixed order; the
last link's TICK(t') then makes barrier t'. A TICK that comes again (one the link already
brought) is handled at once when its frame was handed on (the world asks for a lost ACK), and
dropped while its frame still waits here (the world asked before the bridge was done; the ACK
follows the frame). Pure: the queues only (what a TICK
is, when the bridge is ready, and the handler are passed in).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable


class FrameHold:
    """Vehicle packets held per link, handed on a whole frame at a time, links in a fixed order."""

    def __init__(self, links, handle: Callable[[object, object], None], tick_time: Callable[[object], int | None],
                 active: Callable[[], bool], ready: Callable[[], bool]) -> None:
        self.handle = handle                # (link, packet) -> None: the packet handled
        self.tick_time = tick_time          # packet -> a TICK's time (us), or None
        self.active = active                # () -> True when the world is pipelined
        self.ready = ready                  # () -> True when the bridge is done with its newest barrier
        self.queues: dict[object, deque] = {link: deque() for link in links}     # (packet, TICK time or None), links' order
        self.ends: dict[object, deque] = {link: deque() for link in links}       # TICK times queued
        self.newest: dict[object, int] = {link: -1 for link in links}            # newest TICK the link brought
        self.held = 0                       # packets that waited here, in all
        self._busy = False

    def take(self, link, pkt) -> bool:
        """True when `pkt` waits here (pipelined, and not a TICK the link brought before), or is
        a TICK brought again while its frame still waits here (dropped)."""
        t = self.tick_time(pkt)
        if t is not None:
            if t <= self.newest[link]:
                # again: answered at once once its frame was handled; still queued here, its
                # frame's ACK comes when the frame is handled (handled now, the TICK would count
                # for a barrier before the frame's packets were handled)
                return t in self.ends[link]
            self.newest[link] = t
        if not self.active():
            return False
        self.queues[link].append((pkt, t))         # its TICK time kept: decoded once
        self.held += 1
        if t is not None:
            self.ends[link].append(t)
            self.release()
        return True

    def release(self) -> None:
        """Hand on every frame that is complete on all links, while the bridge is ready for it.
        A call from inside a handler returns at once; the outer call's loop goes on."""
        if self._busy:
            return
        self._busy = True
        try:
            while self.ready():
                queued = [e[0] for e in self.ends.values() if e]
                if not queued:
                    return
                t = min(queued)
                # complete on every link: its TICK(t) queued, or already handed on
                if any(not (e and e[0] == t) and self.newest[link] < t for link, e in self.ends.items()):
                    return
                for link, e in self.ends.items():
                    if e and e[0] == t:
                        self._hand_on(link, t)
        finally:
            self._busy = False

    def _hand_on(self, link, t: int) -> None:
        """The link's packets up to and including its TICK(t)."""
        q, e = self.queues[link], self.ends[link]
        e.popleft()
        while q:
            pkt, tick = q.popleft()
            self.handle(link, pkt)
            if tick == t:
                return

    def waiting(self) -> int:
        """Packets waiting now."""
        return sum(len(q) for q in self.queues.values())
