"""The world's lockstep gate: who the world waits for, and whether it may step on.

Pure: no sockets, no clocks of its own (wall times are passed in). The world
(vehicle/world.py) feeds it every TOWERLINK_LOCKSTEP it receives (common.mavlink.lockstep) with the
vehicle index whose endpoint it arrived on and the reply channel, and asks it:

* ``started(wall)``: may the world leave t = 0? When ``expect`` participants have joined on
  every vehicle, or on the one vehicle their JOIN named (target_system: a driver of one
  vehicle on that vehicle's own link, such as the van's; 0 = every vehicle) (so the run starts at the same sim time whatever the machine), or when
  ``timeout`` wall seconds passed since the first JOIN (then it starts with whoever is there);
* ``awaited(boundary)``: the TICK whose ACKs the world needs before it leaves a boundary:
  that boundary's own (``lag`` 0), or the one before it (``lag`` 1, pipelined: the world
  sends TICK(t) and steps on at once, and waits for ACK(t) at t + one period);
* ``passed(t_usec)``: has every registered participant acknowledged sim time t on every
  vehicle link it joined on? Per link, because UDP keeps order only per socket pair: a
  reaction sent to vehicle 1 before the ACK is known to have arrived only when the ACK came
  on vehicle 1's endpoint too;
* ``due(sysid, compid, vehicle, channel)``: the TICK boundary at which a packet takes effect,
  fixed by the data, never by when the machine delivered it: a participant whose newest ACK
  on that link is a reacted to TICK(a + period), so its packet takes effect at a + (1 + lag)
  periods (before any ACK: at lag periods), the boundary where the world waits for the ACK
  that follows it. None for anyone else's (handled on arrival, an ordinary vehicle); with
  lag 1 a packet from another system on an address a participant joined from (a tf2 node's
  goal through the bridge) is the participant's, since the world no longer stands still while
  it comes;
* ``holds(sysid, compid, vehicle, boundary)``: must this packet wait for a later TICK
  boundary than the one the world stands at (None: it is between TICKs)?
* ``drop_silent(wall)``: participants not heard from for ``timeout`` wall seconds, dropped
  (returned, to be logged) so the world goes on.

A participant is a (sysid, compid) pair: a tower behind a bridge shares the bridge's
address but is its own participant. TICKs go to every channel a participant joined from,
once per channel.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from common.mavlink.lockstep import ACK, JOIN, LEAVE, PARTICIPANT_NAMES, Lockstep


@dataclass
class Participant:
    sysid: int
    compid: int
    kind: int
    heard: float                                           # wall s, last message from it
    acked: dict[int, int] = field(default_factory=dict)     # vehicle index -> newest ACK, us
    channels: dict[int, object] = field(default_factory=dict)  # vehicle index -> reply channel
    only: int = 0                                          # sysid its JOIN named (0: every vehicle)

    @property
    def name(self) -> str:
        return f"{PARTICIPANT_NAMES.get(self.kind, 'participant')} (sysid {self.sysid}, compid {self.compid})"


class LockstepGate:
    def __init__(self, vehicles: int, expect: int = 1, timeout: float = 10.0,
                 period_usec: int = 40000, lag: int = 0) -> None:
        self.vehicles = vehicles           # number of vehicles in the world
        self.expect = expect               # participants to wait for before leaving t = 0
        self.timeout = timeout             # wall s of silence before a participant is dropped
        self.period_usec = period_usec     # sim us between TICKs
        self.lag = lag                     # TICKs between a TICK and its reactions taking effect (0 or 1)
        self.participants: dict[tuple[int, int], Participant] = {}
        self.first_join: float | None = None
        self.is_started = False
        self.dropped = 0

    def on_message(self, m: Lockstep, vehicle: int, channel, wall: float,
                   now_usec: int | None = None) -> str | None:
        """Take one TOWERLINK_LOCKSTEP received on `vehicle`'s endpoint; a log line or None.

        `now_usec`: the newest TICK already sent, once running: a participant joining then
        (a restarted bridge, a tower back after being dropped) is waited for from the next
        TICK on, since it never got that one."""
        key = (m.sysid, m.compid)
        p = self.participants.get(key)
        if m.kind == LEAVE:
            if p is not None:
                del self.participants[key]
                return f"lockstep: {p.name} left"
            return None
        if m.kind not in (JOIN, ACK):
            return None
        line = None
        if p is None:
            p = self.participants[key] = Participant(m.sysid, m.compid, m.participant, wall,
                                                     only=m.target_system)
            if self.first_join is None:
                self.first_join = wall
            line = f"lockstep: {p.name} joined"
        p.heard = wall
        if vehicle not in p.channels:
            p.channels[vehicle] = channel
            p.acked.setdefault(vehicle, -1 if now_usec is None else now_usec)
        if m.kind == ACK:
            p.acked[vehicle] = max(p.acked.get(vehicle, -1), m.time_usec)
        return line

    def started(self, wall: float) -> bool:
        if not self.is_started:
            full = [p for p in self.participants.values() if p.only or len(p.channels) >= self.vehicles]
            if len(full) >= self.expect or (self.first_join is not None and wall - self.first_join >= self.timeout):
                self.is_started = True
        return self.is_started

    def awaited(self, boundary_usec: int) -> int:
        """The TICK (sim us) every ACK of which the world needs before it leaves `boundary_usec`."""
        return boundary_usec - self.lag * self.period_usec

    def passed(self, t_usec: int) -> bool:
        # (plain loops: asked at every ACK the world waits on, where a generator costs more)
        for p in self.participants.values():
            for a in p.acked.values():
                if a < t_usec:
                    return False
        return True

    def waiting_for(self, t_usec: int) -> list[Participant]:
        return [p for p in self.participants.values() if any(a < t_usec for a in p.acked.values())]

    def drop_silent(self, wall: float, t_usec: int) -> list[Participant]:
        """Participants that owe an ACK for t and were silent for `timeout` wall s: removed."""
        gone = [p for p in self.waiting_for(t_usec) if wall - p.heard >= self.timeout]
        for p in gone:
            del self.participants[(p.sysid, p.compid)]
            self.dropped += 1
        return gone

    def due(self, sysid: int, compid: int, vehicle: int, channel=None) -> int | None:
        """The TICK boundary (sim us) at which a packet from (sysid, compid), received now on
        `vehicle`'s endpoint from `channel`, takes effect; None: on arrival (not a participant's)."""
        p = self.participants.get((sysid, compid))
        if p is not None:
            acked = p.acked.get(vehicle, -1)
        elif self.lag and channel is not None:
            # another system behind a participant's address: in order with that address's ACKs
            acks = [q.acked.get(vehicle, -1) for q in self.participants.values() if q.channels.get(vehicle) is channel]
            if not acks:
                return None
            acked = min(acks)
        else:
            return None
        return (acked // self.period_usec + 1 + self.lag) * self.period_usec

    def holds(self, sysid: int, compid: int, vehicle: int, boundary_usec: int | None, channel=None) -> bool:
        """Must a packet from (sysid, compid) on `vehicle`'s endpoint wait for a later TICK?

        Yes for a participant's packet while the world is between TICKs (boundary None), or
        when it is due after the TICK the world stands at (lag 0: the participant already
        ACKed that TICK, so the packet belongs to the next frame). Packets of anyone else are
        handled on arrival (an ordinary vehicle)."""
        due = self.due(sysid, compid, vehicle, channel)
        return due is not None and (boundary_usec is None or due > boundary_usec)

    def owed(self, t_usec: int) -> list[tuple[int, object]]:
        """(vehicle, channel) of every participant that has not ACKed t there: where a TICK(t)
        that may have been lost is sent again (each channel once per vehicle)."""
        out: list[tuple[int, object]] = []
        for p in self.participants.values():
            for vehicle, a in p.acked.items():
                ch = p.channels.get(vehicle)
                if a < t_usec and ch is not None and all(v != vehicle or c is not ch for v, c in out):
                    out.append((vehicle, ch))
        return out

    def channels(self, vehicle: int) -> list:
        """Where TICKs for `vehicle` go: each joined channel once."""
        out: list = []
        for p in self.participants.values():
            ch = p.channels.get(vehicle)
            if ch is not None and all(ch is not c for c in out):
                out.append(ch)
        return out
