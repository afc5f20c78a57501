"""A pipelined lockstep's next frame, held per vehicle link until the bridge is done with this one.

In a pipelined lockstep (the world's TICKs say lag 1, `sitl --lockstep-pipeline`) the world
sends TICK(t) and steps on at once, so a vehicle link brings the next frame's packets, stamped
after t, while the bridge may still be at barrier t: TICK(t) not yet in on another link, or
the tower (or the nodes) not yet done acting on t. Whatever the bridge did with those packets
then (the frame tree, the follower, the telemetry translated for the tower, the tower's goals
translated against that tree) would depend on how fast each process ran. So a link's packets
after its newest TICK(t) wait here until barrier t is done (bridge.lockstep_desk.holds), and
are then handled in the order they came, link by link in the links' order (fixed, not the order
in which they happened to start holding); one of them may be the link's next TICK, and the link
holds again from there. Pure: the queues only (the predicate and the handler are passed in).
"""
from __future__ import annotations

from collections import deque
from collections.abc import Callable


class FrameHold:
    """Packets held per link, in arrival order, handed on in order once their link is free."""

    def __init__(self, links, holds: Callable[[object], bool], handle: Callable[[object, object], None]) -> None:
        self.holds = holds                  # (link) -> True while the link's newest TICK is not done
        self.handle = handle                # (link, packet) -> None: the packet handled
        self.queues: dict[object, deque] = {link: deque() for link in links}     # in the links' order
        self.held = 0                       # packets that waited here, in all
        self._busy = False

    def take(self, link, pkt) -> bool:
        """True when `pkt` waits here: its link holds, or has packets waiting before it."""
        q = self.queues[link]
        if not q and not self.holds(link):
            return False
        q.append(pkt)
        self.held += 1
        return True

    def release(self) -> None:
        """Hand on, in order, what every free link holds (again while handling frees more:
        one of them may be the TICK that completes a barrier). A call from inside a handler
        returns at once; the outer call's loop sees what it freed."""
        if self._busy:
            return
        self._busy = True
        try:
            more = True
            while more:
                more = False
                for link, q in self.queues.items():
                    while q and not self.holds(link):
                        self.handle(link, q.popleft())
                        more = True
        finally:
            self._busy = False

    def waiting(self) -> int:
        """Packets waiting now."""
        return sum(len(q) for q in self.queues.values())
