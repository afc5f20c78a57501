"""The bridge as a lockstep participant (`towerlink bridge --lockstep`).

The world (``towerlink sitl --lockstep N``) sends TOWERLINK_LOCKSTEP TICK(t) on each
vehicle link after everything it sent up to sim time t. UDP keeps order per socket pair,
so when TICK(t) has arrived on *every* vehicle link the bridge has handled every vehicle
packet up to t (the loop handles packets in arrival order). Then, at that barrier:

1. the bridge's sim-time upkeep runs (goal retries, the follower's stale check and its
   mode/arm retries) on the barrier's clock, never on the wall clock;
2. ACK(t) goes to every vehicle link, after everything the bridge sent in reaction, each in a
   datagram of its own (the world reads a TOWERLINK_LOCKSTEP only at a datagram's start);
3. TICK(t) goes to the tower (with the world's period and lag), if the tower joined, queued
   behind the tower's telemetry (one datagram with it, written at the end of the loop's pass
   or the upkeep's) (its JOIN/ACK/LEAVE pass through the bridge to the world like any
   broadcast, on the same socket as its goals, so a goal sent before the tower's ACK reaches
   the vehicle before it).

With nodes in lockstep (--nodes with --lockstep, bridge.node_lockstep) `nodes` holds steps 2 and 3
until the nodes have settled at t; a TICK the world sends again meanwhile is answered with the
newest barrier already released, never the held one.

Pipelined (the world's TICKs say lag 1: `sitl --lockstep-pipeline`): the world steps on at once
after TICK(t), so a link may bring the next frame's packets while the bridge is still at t. The
barrier t is *done* once it was released and the tower (if it joined) ACKed t, i.e. acted on
it, its goals translated against the frame tree as it stood at t; until then the next frame's
packets wait (:meth:`frame_ready`, bridge.frame_hold), and `on_free` hands them on. A
tower that owes an ACK and says nothing for TOWER_SILENT wall s is no longer waited for (it
joins again with its next JOIN or ACK).

When the bridge closes it sends LEAVE on every vehicle link.

Until the first TICK arrives on a link the bridge sends JOIN there every JOIN_PERIOD wall s,
and again when no TICK came for REJOIN_AFTER wall s (the world dropped it, or restarted).

UDP may drop a datagram when a reader falls behind (a tower handling 100 drones' telemetry):
a TICK to the tower not acknowledged within TICK_RESEND wall s is sent again, and the tower
answers a TICK it already handled with its ACK again (gcs.client), which the bridge routes
on to the world like the first, so one lost TICK or ACK costs a moment, never the run. The
world does the same on the vehicle links: a TICK it sends again, one the barrier has passed,
is ACKed again on that link and sent to the tower again.
"""
from __future__ import annotations

from common.mavlink.dialect import towerlink as tl

# wall s between JOINs on a link that has had no TICK yet: a JOIN sent before the world listens is
# lost, and the world waits at t = 0 for every participant, so this is start-up time of each run
JOIN_PERIOD = 0.1
REJOIN_AFTER = 1.0              # wall s without a TICK on a link: JOIN again (the world dropped us or restarted)
TICK_RESEND = 0.5               # wall s without the tower's ACK of its newest TICK: send that TICK again
TOWER_SILENT = 10.0             # pipelined: wall s of a tower owing an ACK before the links stop waiting for it


class LockstepDesk:
    def __init__(self, vehicles: dict, pack_own, send_tower, on_barrier, log, wall, nodes=None,
                 on_free=None) -> None:
        self.wall = wall                    # () -> wall s (only for JOIN resends)
        self.tick_wall: dict[str, float] = {}
        self.vehicles = vehicles            # sysid -> VehicleRecord
        self.pack_own = pack_own            # message -> bytes (the bridge's own packet)
        self.send_tower = send_tower        # bytes -> None (the tower link's queue: behind its telemetry)
        self.on_barrier = on_barrier        # (t seconds) -> None: the sim-time upkeep
        self.nodes = nodes                  # bridge.node_lockstep.NodeLockstep, or None
        self.on_free = on_free              # () -> None: a barrier is done, the held links may go on
        self.lag = 0                        # the world's TICKs: 1 when pipelined
        self.done_usec = -1                 # pipelined: the newest barrier done (released, the tower acted)
        self.tower_heard = 0.0              # wall s of the tower's newest TOWERLINK_LOCKSTEP
        self.tower_owes_since = 0.0         # wall s the newest barrier's TICK first went to the tower
        self.released_usec = -1             # the newest barrier ACKed to the world
        self.log = log
        self.ticks: dict[str, int] = {}     # vehicle link name -> newest TICK, us
        self._at: dict[int, int] = {}       # TICK time, us -> how many links' newest it is
        self.barrier_usec = -1
        self.period_usec = 0
        self.tower_joined = False
        self.tower_acked = -1               # newest ACK seen from the tower, us
        self.tower_tick_wall = 0.0          # when its newest TICK was sent (wall s)
        self.tick_resends = 0               # TICKs sent to the tower again
        self.tick_resends_seen = 0          # TICKs the world sent again (answered again)
        self._next_join = 0.0
        self.barriers = 0
        self._gcs_due = False               # a barrier released or a TICK queued for the tower since gcs_due()

    @property
    def sim_now(self) -> float:
        """The barrier's sim time (s): the bridge's behaviour clock in lockstep."""
        return max(self.barrier_usec, 0) / 1e6

    def on_node(self, sysid: int, compid: int, msg) -> None:
        """A TOWERLINK_LOCKSTEP from a node on the node link (the bridge's participant, not the world's)."""
        if self.nodes is not None:
            self.nodes.on_message(sysid, compid, msg)

    def frame_ready(self) -> bool:
        """Pipelined: is the newest barrier done, so the next frame's packets may be handled?"""
        return self.done_usec >= self.barrier_usec

    def _free(self) -> None:
        """Pipelined: note how far the barriers are done; the held links go on (on_free)."""
        done = self.released_usec if not self.tower_joined else min(self.released_usec, self.tower_acked)
        if done > self.done_usec:
            self.done_usec = done
            if self.on_free is not None:
                self.on_free()

    def tower_done(self) -> None:
        """After a TOWERLINK_LOCKSTEP of the tower went on to the world: its ACK may finish a barrier."""
        if self.lag:
            self._free()

    def upkeep(self, wall: float) -> None:
        if self.nodes is not None:
            self.nodes.upkeep()
        if self.lag and self.tower_joined and self.released_usec > self.tower_acked and \
                wall - max(self.tower_heard, self.tower_owes_since) >= TOWER_SILENT:
            self.tower_joined = False
            self.log(f"lockstep: the tower owes ACK({self.released_usec / 1e6:g} s) and was silent for "
                     f"{TOWER_SILENT:g} s (wall): the vehicle links go on without it")
            self._free()
        if self.tower_joined and self.released_usec > self.tower_acked and \
                wall - self.tower_tick_wall > TICK_RESEND:
            self.tick_resends += 1
            self._tick_tower(wall)
        if wall < self._next_join:
            return
        self._next_join = wall + JOIN_PERIOD
        for v in self.vehicles.values():
            if v.name not in self.ticks or wall - self.tick_wall.get(v.name, wall) > REJOIN_AFTER:
                v.link.send(self.pack_own(self._message(tl.TOWERLINK_LOCKSTEP_KIND_JOIN, 0, v.sysid)))

    def on_vehicle(self, v, msg) -> None:
        """A TOWERLINK_LOCKSTEP from a vehicle link (the world's TICK)."""
        if msg.kind != tl.TOWERLINK_LOCKSTEP_KIND_TICK:
            return
        if 0 <= msg.time_usec <= self.barrier_usec and v.name in self.ticks:
            self._again(v)      # the world sent it again: our ACK, or the tower's, was lost
            return
        if v.name not in self.ticks:
            self.log(f"lockstep: {v.name} link ticks (every {msg.period_usec / 1e3:g} ms sim)")
        old = self.ticks.get(v.name)
        new = msg.time_usec if old is None else max(old, msg.time_usec)
        self.ticks[v.name] = new
        if new != old:          # how many links stand at each TICK: the barrier is the lowest
            if old is not None:
                self._at[old] -= 1
                if not self._at[old]:
                    del self._at[old]
            self._at[new] = self._at.get(new, 0) + 1
        self.tick_wall[v.name] = self.wall()
        self.period_usec = msg.period_usec
        self.lag = msg.lag
        if len(self.ticks) < len(self.vehicles):
            return
        # min over the few TICK times links stand at (a frame or two apart), not over every
        # link: with 100 vehicle links a min per TICK made each frame O(links**2)
        barrier = min(self._at)
        if barrier <= self.barrier_usec:
            return
        self.barrier_usec = barrier
        self.barriers += 1
        self.on_barrier(barrier / 1e6)
        if self.nodes is None or not self.nodes.hold(barrier, lambda: self._release(barrier)):
            self._release(barrier)

    def gcs_due(self) -> bool:
        """True once after each barrier released or TICK queued for the tower: the loop's pass
        then writes the GCS links (bridge.socket_loop), the telemetry up to it with the TICK."""
        due, self._gcs_due = self._gcs_due, False
        return due

    def _release(self, barrier: int) -> None:
        """ACK(barrier) to the world on every vehicle link, then TICK the tower."""
        self.released_usec = barrier
        self._gcs_due = True
        for w in self.vehicles.values():
            w.link.send(self.pack_own(self._message(tl.TOWERLINK_LOCKSTEP_KIND_ACK, barrier, w.sysid)))
        if self.tower_joined:
            self.tower_owes_since = self.wall()
            self._tick_tower(self.tower_owes_since)
        if self.lag:
            self._free()

    def _again(self, v) -> None:
        """A TICK the barrier has passed came again on v's link: ACK it again there, and TICK
        the tower again (it ACKs a TICK it already handled again, which passes on to the world)."""
        self.tick_resends_seen += 1
        if self.released_usec < 0:
            return              # nothing released yet (TICK(0) held for the nodes): no ACK to repeat
        v.link.send(self.pack_own(self._message(tl.TOWERLINK_LOCKSTEP_KIND_ACK, self.released_usec, v.sysid)))
        if self.released_usec < self.barrier_usec:
            return              # held for the nodes: the tower's TICK comes with the release
        wall = self.wall()
        # the world asks on every link the tower ACKs through: one TICK to the tower for them all
        if self.tower_joined and wall - self.tower_tick_wall >= TICK_RESEND / 2:
            self._tick_tower(wall)

    def _tick_tower(self, wall: float) -> None:
        self.tower_tick_wall = wall
        self._gcs_due = True
        self.send_tower(self.pack_own(tl.MAVLink_towerlink_lockstep_message(
            self.released_usec, 0, tl.TOWERLINK_LOCKSTEP_KIND_TICK, tl.TOWERLINK_LOCKSTEP_PARTICIPANT_WORLD,
            self.period_usec, self.lag)))

    def on_tower(self, msg) -> None:
        """A TOWERLINK_LOCKSTEP from the tower (routed on to the world by the loop, then tower_done)."""
        self.tower_heard = self.wall()
        if msg.kind in (tl.TOWERLINK_LOCKSTEP_KIND_JOIN, tl.TOWERLINK_LOCKSTEP_KIND_ACK):
            if not self.tower_joined:
                self.log("lockstep: the tower joined; its TICKs follow the world's")
            self.tower_joined = True
            if msg.kind == tl.TOWERLINK_LOCKSTEP_KIND_ACK:
                self.tower_acked = max(self.tower_acked, msg.time_usec)
        elif msg.kind == tl.TOWERLINK_LOCKSTEP_KIND_LEAVE:
            self.tower_joined = False
            self.log("lockstep: the tower left")

    def leave(self) -> None:
        """LEAVE on every vehicle link: the bridge is going, so the world need not wait out its
        --lockstep-timeout (a world started by hand, or one a restarted bridge will join again)."""
        for v in self.vehicles.values():
            try:
                v.link.send(self.pack_own(self._message(tl.TOWERLINK_LOCKSTEP_KIND_LEAVE, max(self.barrier_usec, 0), v.sysid)))
            except OSError:             # a link already gone has no world to tell
                pass

    @staticmethod
    def _message(kind: int, t_usec: int, target: int):
        return tl.MAVLink_towerlink_lockstep_message(t_usec, target, kind,
                                                     tl.TOWERLINK_LOCKSTEP_PARTICIPANT_BRIDGE, 0)
