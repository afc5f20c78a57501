"""fly's monitor as a lockstep participant on the world's push link (pure: no sockets, no clocks).

The world pushes every vehicle's telemetry to the monitor over UDP (sitl --out udpout). A
reader that falls behind loses datagrams (the kernel drops what no longer fits its receive
buffer), and with them SIM_STATE, the truth the summary scores: at --speedup max on a busy
machine the recording, not the flight, then differed from run to run. So in lockstep the
monitor is a participant like the bridge: it JOINs on each vehicle's push link (at the
address the vehicle sends from, heard from the HEARTBEAT the world sends there while it waits
at t = 0), and ACKs each TICK only once it has read everything that came before it. The world
is then never more than one lockstep frame ahead of the recording (two when pipelined: it
steps the next frame while it waits for this ACK; the monitor only records, so what it reads
after a TICK before ACKing it changes nothing).

:class:`PushLockstep` keeps the bookkeeping per vehicle address (wall times are passed in):
where to JOIN (no TICK yet, at most every JOIN_PERIOD wall s), which TICK each address is
owed an ACK for (common.mavlink.tick_clock.TickClock: a TICK that comes again after its ACK is
ACKed again), and where to say LEAVE.
"""
from __future__ import annotations

from common.mavlink.tick_clock import TickClock

JOIN_PERIOD = 0.5           # wall s between JOINs to a vehicle that has not TICKed yet


class PushLockstep:
    def __init__(self) -> None:
        self.clocks: dict[tuple, TickClock] = {}        # vehicle address -> its TICKs
        self._joined_at: dict[tuple, float] = {}        # vehicle address -> last JOIN, wall s
        self._again: list[tuple[tuple, int]] = []        # (address, TICK) to ACK again at once

    def heard(self, addr, wall: float) -> bool:
        """A datagram came from the vehicle at `addr`: True when a JOIN should go there now."""
        if addr in self.clocks:
            return False
        if wall - self._joined_at.get(addr, -1e9) < JOIN_PERIOD:
            return False
        self._joined_at[addr] = wall
        return True

    def on_tick(self, addr, time_usec: int) -> None:
        """A TICK from the vehicle at `addr` (ACKed by :meth:`acks` once what came before it was read)."""
        clock = self.clocks.setdefault(addr, TickClock())
        again = clock.on_tick(time_usec)
        if again is not None:
            self._again.append((addr, again))

    def acks(self) -> list[tuple[tuple, int]]:
        """(address, TICK us) to ACK now: everything received so far has been read."""
        out, self._again = self._again, []
        for addr, clock in self.clocks.items():
            due = clock.take_ack()
            if due is not None:
                out.append((addr, due))
        return out

    def addresses(self) -> list:
        """Every vehicle address JOINed or TICKed (where LEAVE goes)."""
        return list({**self._joined_at, **self.clocks})
