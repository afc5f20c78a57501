"""The nodes on the bridge's node link as lockstep participants of the bridge (`--lockstep` with `--nodes`).

The nodes (common.tf2_ros, lockstep on) JOIN the bridge, not the world: their TOWERLINK_LOCKSTEP
never goes on. At each barrier (every vehicle link's TICK(t) came, the sim-time upkeep ran) the
bridge holds its ACK(t) to the world and settles the nodes first:

1. TICK(t) goes to the node link, after everything queued for it (the telemetry up to t);
2. each node handles what came before the TICK, runs its loop for t, sends its reactions
   (routed at once: a rover goal reaches the world, paused at t, before the bridge's ACK), and ACKs;
3. when every node has ACKed, the round is over -- unless the bridge sent the node link anything
   besides the TICK meanwhile (a node's transform republished on the stream, which another node
   reacts to): then TICK(t) goes again, and the nodes ACK again after handling it. The bridge
   numbers its rounds in the TICK's period_usec and a node's ACK carries the number back, so an
   ACK late from one round never counts for the next, and a TICK sent again is harmless;
4. a round with nothing new settles t: the bridge ACKs the world (bridge.lockstep_desk).

Before the first release it waits for `expect` nodes to JOIN (or LEAVE: a node that failed),
at most JOIN_TIMEOUT wall s. A node that owes an ACK and says nothing for SILENT_AFTER wall s is
dropped (logged), so a node that hangs or dies costs seconds, never the run. Pure: no sockets of
its own (the node Link and the wall clock are passed in).
"""
from __future__ import annotations

from dataclasses import dataclass

from common.mavlink import lockstep as ls
from common.mavlink.dialect import towerlink as tl

JOIN_TIMEOUT = 15.0     # wall s, from the first barrier, to wait for the expected nodes
SILENT_AFTER = 10.0     # wall s without a word from a node that owes an ACK: dropped (the world: 10 too)
TICK_RESEND = 0.5       # wall s without the ACKs of a round: TICK again (UDP may drop one)


@dataclass
class NodePeer:
    sysid: int
    compid: int
    heard: float
    acked: tuple[int, int] = (-1, -1)     # (t us, round) of its newest ACK


class NodeLockstep:
    def __init__(self, link, pack_own, expect: int, log, wall) -> None:
        self.link = link                    # the node Link: send(), flush(), stats.tx_packets
        self.pack_own = pack_own            # message -> bytes as the bridge
        self.expect = expect                # nodes to wait for before the first release
        self.log = log
        self.wall = wall
        self.nodes: dict[tuple[int, int], NodePeer] = {}
        self.left: set[tuple[int, int]] = set()
        self.pending: tuple[int, object] | None = None    # (t us, release) held at a barrier
        self.first_hold: float | None = None
        self.round_wall = 0.0
        self.round_no = 0                   # this barrier's round, sent as the TICK's period_usec
        self.mark = -1                      # the link's tx count just after the newest TICK round
        self.rounds = 0
        self.settled = 0
        self.dropped = 0

    # -- the barrier (bridge.lockstep_desk calls hold)

    def hold(self, t_usec: int, release) -> bool:
        """At the barrier t: True when `release()` will be called once the nodes settled at t,
        False when there is nothing to wait for (release it now)."""
        if self.pending is not None:        # never two at once: the world waits for our ACK
            self._release()
        if not self.nodes and self._all_came():
            return False
        if self.first_hold is None:
            self.first_hold = self.wall()
        self.pending = (t_usec, release)
        self.round_no = 0
        self._round()
        return True

    def _all_came(self) -> bool:
        return len(self.nodes) + len(self.left) >= self.expect or (
            self.first_hold is not None and self.wall() - self.first_hold >= JOIN_TIMEOUT)

    def _owed(self) -> list[NodePeer]:
        want = (self.pending[0], self.round_no)
        return [n for n in self.nodes.values() if n.acked != want]

    def _round(self, again: bool = False) -> None:
        """TICK(t) to the nodes: a new round, or (again) the current one once more."""
        if not again:
            self.round_no += 1
            self.rounds += 1
        self.round_wall = self.wall()
        self.link.send(self.pack_own(tl.MAVLink_towerlink_lockstep_message(
            self.pending[0], 0, tl.TOWERLINK_LOCKSTEP_KIND_TICK, tl.TOWERLINK_LOCKSTEP_PARTICIPANT_BRIDGE,
            self.round_no)))
        if not again:   # a TICK sent again leaves the mark behind: one more round follows, to be sure
            self.mark = self.link.stats.tx_packets

    def _check(self) -> None:
        if self.pending is None or self._owed() or not self._all_came():
            return
        self.link.flush()
        if self.link.stats.tx_packets != self.mark and self.nodes:
            self._round()                   # the nodes got something new: let them react to it
            return
        self._release()

    def _release(self) -> None:
        _t, release = self.pending
        self.pending = None
        self.settled += 1
        release()

    # -- the node link

    def on_message(self, sysid: int, compid: int, msg) -> None:
        """A TOWERLINK_LOCKSTEP from a node (JOIN, ACK, LEAVE)."""
        key, now = (sysid, compid), self.wall()
        n = self.nodes.get(key)
        if msg.kind == ls.LEAVE:
            if n is not None:
                del self.nodes[key]
                self.log(f"lockstep: node {sysid}/{compid} left")
            self.left.add(key)
            self._check()
            return
        if msg.kind not in (ls.JOIN, ls.ACK):
            return
        if n is None:
            n = self.nodes[key] = NodePeer(sysid, compid, now)
            self.left.discard(key)
            self.log(f"lockstep: node {sysid}/{compid} joined ({len(self.nodes)} of {self.expect} expected)")
            if self.pending is not None:    # it gets this round's TICK too
                self._round(again=True)
                return
        n.heard = now
        if msg.kind == ls.ACK:
            n.acked = (msg.time_usec, msg.period_usec)
        self._check()

    def upkeep(self) -> None:
        """Every wall tick: drop silent nodes, TICK again when a round's ACKs are late, and let
        the barrier go once the join wait is over."""
        if self.pending is None:
            return
        now = self.wall()
        owed = self._owed()
        for n in owed:
            if now - n.heard >= SILENT_AFTER:
                key = (n.sysid, n.compid)
                del self.nodes[key]
                self.left.add(key)
                self.dropped += 1
                self.log(f"lockstep: node {n.sysid}/{n.compid} silent for {SILENT_AFTER:g} s (wall): "
                         f"dropped, the world goes on")
        if self._owed() and now - self.round_wall >= TICK_RESEND:
            self._round(again=True)
            return
        self._check()

    def summary(self) -> str:
        return (f"node lockstep: {len(self.nodes)} node(s) in, {len(self.left)} left or dropped "
                f"({self.dropped} for silence); {self.settled} barriers settled in {self.rounds} TICK rounds")
