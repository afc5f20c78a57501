"""A client's side of the world's lockstep (TOWERLINK_LOCKSTEP, common.mavlink.lockstep), pure.

The world's newest TICK is the client's clock. A TICK is ACKed only once the program has acted
on it (at the client's next poll), and a TICK that comes again after its ACK was sent is ACKed
again at once: common.mavlink.tick_clock.TickClock keeps those books (its home; named here for
the client); sending is the link's business (gcs.client.link).
"""
from __future__ import annotations

from common.mavlink.tick_clock import TickClock

__all__ = ["JOIN_PERIOD", "LOCKSTEP_TIMEOUT", "TickClock"]

#: wall s a lockstep client waits for the world's next TICK before it gives up (ClientTimeout)
LOCKSTEP_TIMEOUT = 15.0
#: wall s between a client's JOINs until the first TICK (one sent before the world listens is lost;
#: the world waits at t = 0 for every participant)
JOIN_PERIOD = 0.1
