"""The world's side of the lockstep handshake: the I/O around the pure gate.

`WorldLockstep` reads TOWERLINK_LOCKSTEP (common.mavlink.lockstep) off every UDP endpoint before the
vehicle's link sees it (the link speaks ardupilotmega; this one message is the world's):
each vehicle's link is given `intake(index)`, which sees its datagrams first,
feeds the gate (vehicle.lockstep), sends the TICKs and waits for the ACKs. The world's
stepping loop asks :meth:`WorldLockstep.boundary` before every step.

A participant's packets take effect at a TICK boundary fixed by its newest ACK on that link
(vehicle.lockstep.LockstepGate.due): without pipelining the one the world stands at if the
participant has not ACKed that TICK yet, else the next; pipelined (`lag` 1, sitl
--lockstep-pipeline) one TICK later, since the world sends TICK(t), steps on at once and waits
for ACK(t) only at t + one period, before it sends that TICK. A packet due later than the
boundary the world stands at is held until then. So each takes effect at a sim time fixed by
the data it reacts to, never by when the machine delivered it. Anyone else's packets are handled on arrival: third-party clients see an ordinary
vehicle, and never a TOWERLINK_LOCKSTEP (TICKs go only to the addresses participants
joined from). A TICK still owed an ACK after TICK_RESEND wall s is sent again to whoever
owes it, so one lost datagram on a vehicle link costs half a second, never the run (a
participant that keeps JOINing is never silent, so dropping would not free the world).
With --signing-key a TOWERLINK_LOCKSTEP must be signed with the key (else it is dropped and
counted as the link counts any unsigned packet) and the TICKs are signed.
"""
from __future__ import annotations

import asyncio
import functools
import time

from common.mavlink import lockstep as wire
from vehicle.link.endpoints import UdpOut
from vehicle.link.link_core import Intake, LinkCore
from vehicle.lockstep import LockstepGate

TICK_RESEND = 0.5       # wall s without every ACK: TICK again to whoever owes one (UDP may drop either)
ANNOUNCE_PERIOD = 0.5   # wall s between the HEARTBEATs on the push links while the world waits at t = 0
MSG_HEARTBEAT = 0


def _wake(w: asyncio.Future) -> None:
    if not w.done():
        w.set_result(None)


class WorldLockstep:
    def __init__(self, world, vehicles: int, expect: int, period: float, timeout: float, lag: int = 0) -> None:
        """world: its dt, ap_every, steps, outbox and (once built) vehicles; vehicles: how many
        this process runs; expect participants; a TICK every `period` sim s; `timeout` wall s;
        `lag` 1: pipelined (reactions to TICK(t) take effect at t + period), 0: not."""
        self.world = world
        ap_dt = world.dt * world.ap_every
        # TICKs fall on autopilot ticks, so a TICK always follows that tick's telemetry
        self.frame_steps = world.ap_every * max(1, int(round(period / ap_dt)))
        self.period_usec = int(round(self.frame_steps * world.dt * 1e6))    # what each TICK says
        self.lag = lag
        self.gate = LockstepGate(vehicles, expect, timeout, self.period_usec, lag)
        self.expect = expect
        self.ticked_steps = -1              # the step of the newest TICK sent
        self.arrived_steps = -1             # the step of the newest boundary reached
        self._waiter: asyncio.Future | None = None    # what wait()/start() sleep on; an ACK or JOIN wakes it
        self._wake_when = None              # the waiter's done(): a TOWERLINK_LOCKSTEP wakes it once true
        self.held: list[tuple[int, LinkCore, bytes, object]] = []     # (due, sim us), in arrival order
        self.at_boundary = True
        self.waits = 0
        self.wait_wall = 0.0
        self.tick_wall = 0.0                # when the newest TICK went out (wall s)
        self.tick_resends = 0
        self.ticks = 0

    def t_usec(self) -> int:
        """The world's sim time in whole microseconds (the TICKs' and ACKs' unit)."""
        w = self.world
        return int(round(w.steps * w.dt * 1e6))

    def intake(self, index: int) -> Intake:
        """What the link of vehicle `index` (world index) hands its UDP datagrams to first."""
        return functools.partial(self._take, index)

    def _take(self, index: int, link: LinkCore, data: bytes, channel) -> bool:
        """A TOWERLINK_LOCKSTEP feeds the gate (the rest of its datagram goes to the link); a
        participant's other packets wait for the TICK boundary they are due at; anyone else's go on."""
        m, rest = wire.unpack(data)
        if m is None:
            sender = wire.sender(data)
            due = None if sender is None else self.gate.due(*sender, index, channel)
            if due is not None and (not self.at_boundary or due > self.t_usec()):
                if link.signing_key:        # judged now, in arrival order with the sender's ACKs
                    data = link.drop_refused_now(data)
                    if not data:
                        return True
                self.held.append((due, link, data, channel))
                return True
            return link.on_data(data, channel)
        # with --signing-key a participant must sign (an unsigned one is counted by the link)
        signed_ok = not link.signing_key or link.signature_ok(data[:len(data) - len(rest)], m.sysid, m.compid)
        if signed_ok and m.target_system in (0, link.sysid):
            now = None
            if self.gate.is_started and self.ticked_steps >= 0:
                now = int(round(self.ticked_steps * self.world.dt * 1e6))
            line = self.gate.on_message(m, index, channel, time.monotonic(), now)
            if line:
                self.world.log(line)
            w = self._waiter
            # wake the waiting world only when what it waits for is there: an ACK that leaves
            # others owed would cost it a loop turn, a future and a timer for nothing
            if w is not None and not w.done() and (line or self._wake_when is None or self._wake_when()):
                w.set_result(None)
        return (link.on_data(rest, channel) if rest else False) or True

    def boundary(self) -> bool:
        """Before each step: True when the world stands at a TICK it may not pass yet.

        At a boundary t the packets due by t take effect (what came before, in arrival order;
        what comes while the world stands there, on arrival), then TICK(t) goes out: at once
        without pipelining, and the world waits for ACK(t); pipelined, once ACK(t - period)
        came from everyone, and the world steps on at once (the TICK and the frame's telemetry
        before it are written now, not at the end of the next frame's chunk)."""
        w = self.world
        if w.steps % self.frame_steps:
            return False
        self.at_boundary = True
        t = self.t_usec()
        if self.arrived_steps != w.steps:
            self.arrived_steps = w.steps
            if self.held:
                self._apply_held(t)
            if not self.lag:
                self._send_ticks()
        if not self.gate.passed(self.gate.awaited(t)):
            return True
        if self.ticked_steps != w.steps:        # pipelined: TICK(t) now, and on without waiting
            self._send_ticks()
            w.outbox.push()
        self.at_boundary = False
        return False

    def _apply_held(self, t: int) -> None:
        """The held packets due by t take effect, in arrival order; the later ones stay held."""
        keep = []
        for item in self.held:
            if item[0] <= t:
                item[1].on_data(item[2], item[3], signed_checked=True)
            else:
                keep.append(item)
        self.held = keep

    def _send_ticks(self) -> None:
        """TICK(t) after everything the vehicles sent up to t, to each joined channel."""
        self.ticked_steps = self.world.steps
        self.ticks += 1
        t = self.t_usec()
        for v in self.world.vehicles:
            frame = None
            for ch in self.gate.channels(v.index):
                # unsigned, a vehicle's TICK is the same bytes on each channel: packed once
                if frame is None or v.link.signing_key:
                    frame = self._tick_frame(v, t)
                ch.send(frame)
        self.tick_wall = time.monotonic()

    def _tick_frame(self, v, t: int) -> bytes:
        """Vehicle v's TICK(t), signed with its link's next signing timestamp when it signs."""
        return wire.pack(wire.TICK, t, participant=wire.WORLD, target_system=0, period_usec=self.period_usec,
                         sysid=v.sysid, compid=1, signing=v.link.take_signing(), lag=self.lag)

    def _tick(self, v, channel, t: int) -> None:
        channel.send(self._tick_frame(v, t))

    def _resend(self, t: int) -> None:
        """TICK(t) again where an ACK is still owed after TICK_RESEND wall s: the TICK or the ACK
        was lost (a participant answers a TICK it already handled with its ACK again)."""
        if time.monotonic() - self.tick_wall < TICK_RESEND:
            return
        by_index = {v.index: v for v in self.world.vehicles}     # world indices (a worker holds some)
        for index, ch in self.gate.owed(t):
            self.tick_resends += 1          # before the send: a test reading it on arrival sees it
            self._tick(by_index[index], ch, t)
        self.tick_wall = time.monotonic()

    async def _until(self, done, stop: asyncio.Event, every=None) -> None:
        """Until done(): sleep until a TOWERLINK_LOCKSTEP made done() true (or said something
        worth a log line) or 0.5 s wall passed, then every(). A bare future and a timer, not
        wait_for on an Event: that made a task and two futures per TICK, a good part of the
        round trip at --speedup max."""
        loop = asyncio.get_running_loop()
        while not done() and not stop.is_set():
            w = self._waiter = loop.create_future()
            self._wake_when = done
            timer = loop.call_later(0.5, _wake, w)
            try:
                await w
            finally:
                timer.cancel()
                self._waiter = self._wake_when = None
            if every is not None:
                every()

    async def wait(self, stop: asyncio.Event) -> None:
        """Until every participant ACKed the TICK the world awaits at the boundary it stands at
        (that boundary's own, or pipelined the one before; or until the silent were dropped)."""
        gate = self.gate
        t = gate.awaited(self.t_usec())
        w0 = time.monotonic()
        self.waits += 1

        def drop_or_resend() -> None:
            for p in gate.drop_silent(time.monotonic(), t):
                self.world.log(f"lockstep: {p.name} silent for {gate.timeout:g} s (wall): dropped, "
                               f"the world goes on")
            if not gate.passed(t):
                self._resend(t)
        await self._until(lambda: gate.passed(t), stop, drop_or_resend)
        self.wait_wall += time.monotonic() - w0

    async def start(self, stop: asyncio.Event) -> None:
        """Hold at t = 0 until the expected participants joined (gate.started)."""
        gate, log = self.gate, self.world.log
        last = [time.monotonic()]
        log(f"lockstep: waiting at t=0 for {self.expect} participant(s) on every vehicle")

        announced = [-ANNOUNCE_PERIOD]

        def remind() -> None:
            if time.monotonic() - announced[0] >= ANNOUNCE_PERIOD:
                announced[0] = time.monotonic()
                self._announce()
            if time.monotonic() - last[0] > 10.0:
                last[0] = time.monotonic()
                log(f"lockstep: still waiting at t=0: {len(gate.participants)} of {self.expect} joined")
        remind()
        await self._until(lambda: gate.started(time.monotonic()), stop, remind)
        log(f"lockstep: starting with {len(gate.participants)} participant(s), a TICK every "
            f"{self.frame_steps * self.world.dt * 1e3:g} ms sim, silent ones dropped after {gate.timeout:g} s wall")

    def _announce(self) -> None:
        """Each vehicle's HEARTBEAT on its push links (udpout) only, while the world waits at
        t = 0: a participant listening where the world pushes (fly's monitor) hears where each
        vehicle sends from, and JOINs there. Nothing goes to the udpin peers (the bridge), whose
        reactions would then depend on the wall clock. The link's sequence number does not move."""
        for v in self.world.vehicles:
            pushes = [ep for ep in v.link.endpoints if isinstance(ep, UdpOut)]
            if pushes:
                buf = v.link.telemetry.frame(MSG_HEARTBEAT)
                for ep in pushes:
                    ep.send(buf)

    def stats_line(self) -> str:
        return (f"lockstep: {self.waits} waits for ACKs, {self.wait_wall:.2f} s wall waiting; "
                f"{self.tick_resends} TICK(s) sent again; {self.gate.dropped} participant(s) dropped for silence; "
                f"{self.ticks} TICKs{', pipelined' if self.lag else ''}")
