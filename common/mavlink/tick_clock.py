"""A lockstep participant's books of the world's TICKs (common.mavlink.lockstep), pure.

The world's newest TICK is the participant's clock. A TICK is ACKed only once the program has
acted on it, and a TICK that comes again after its ACK was sent (the ACK, or the TICK after it,
was lost on the way) is ACKed again at once. :class:`TickClock` keeps that bookkeeping, in the
TICKs' sim microseconds; sending is the participant's business (gcs.client's link, fly's
monitor). Here, in common, so a participant need not import the client package.
"""
from __future__ import annotations


class TickClock:
    """Which TICK is the clock, which one is due an ACK, which one was ACKed last (sim us)."""

    def __init__(self) -> None:
        self.tick_usec: int | None = None   # newest TICK handled
        self.ack_due: int | None = None     # handled, ACK not yet sent
        self.acked = -1                     # newest TICK ACKed

    def now(self) -> float:
        """The newest TICK's sim time, s (0 before the first)."""
        return (self.tick_usec or 0) / 1e6

    def on_tick(self, time_usec: int) -> int | None:
        """Note a TICK; returns the time to ACK again at once when it is one already ACKed."""
        if self.tick_usec is None or time_usec > self.tick_usec:
            self.tick_usec = time_usec
            self.ack_due = time_usec
            return None
        if self.ack_due is None and time_usec <= self.acked:
            return self.acked
        return None

    def take_ack(self) -> int | None:
        """The TICK to ACK now (the program has acted on it), or None; it counts as ACKed."""
        due, self.ack_due = self.ack_due, None
        if due is not None:
            self.acked = due
        return due
