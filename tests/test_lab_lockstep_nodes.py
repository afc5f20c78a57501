"""tf2_ros nodes in the lockstep: the node's sim clock, the bridge's node hub, a node on a real socket.

The node (common.tf2_ros.Node, lockstep on) JOINs the bridge, takes its TICKs as its clock,
runs its loop for each and ACKs after what it sent; the bridge (bridge.node_lockstep) holds
its ACK to the world until every node has ACKed a round with nothing new for them.
"""
from __future__ import annotations

import threading
import time

import pytest

from bridge.lockstep_desk import LockstepDesk
from bridge.node_lockstep import JOIN_TIMEOUT, SILENT_AFTER, NodeLockstep
from common.mavlink import lockstep as ls
from common.mavlink.dialect import mavlink_connection
from common.mavlink.dialect import towerlink as tl
from common.tf2_ros import Node
from common.tf2_ros.sim_clock import LockstepClock
from tests.support import free_port, wait_until


# ----------------------------------------------------------------------------- the node's clock


def test_a_tick_wakes_the_loop_due_and_returns_when_it_sleeps_again():
    clock = LockstepClock()
    done: list[float] = []

    def loop():
        nxt = 0.1
        while clock.sleep_until(nxt):
            time.sleep(0.02)                   # the loop's work for this sim time
            done.append(clock.now())
            nxt += 0.1

    th = threading.Thread(target=loop)
    th.start()
    wait_until(lambda: clock._sleepers, 2, "the loop asleep")
    clock.advance(0.04)                        # not due: returns at once, nothing ran
    assert done == []
    clock.advance(0.12)                        # due: returns only after the loop's work
    assert done == [0.12]
    clock.advance(0.16)
    assert done == [0.12]
    clock.advance(0.20)
    assert done == [0.12, 0.20]
    clock.close()
    th.join(2)
    assert not th.is_alive() and clock.late == 0


def test_a_loop_that_does_not_come_back_is_waited_for_only_the_grace():
    clock = LockstepClock(grace=0.2)
    th = threading.Thread(target=lambda: clock.sleep_until(0.1) and time.sleep(5), daemon=True)
    th.start()
    wait_until(lambda: clock._sleepers, 2, "the loop asleep")
    t0 = time.monotonic()
    clock.advance(0.2)
    assert 0.15 < time.monotonic() - t0 < 2 and clock.late == 1
    clock.advance(0.3)                         # not asleep: not waited for again
    assert clock.late == 1
    clock.close()


# ----------------------------------------------------------------------------- the bridge's hub


class FakeLink:
    """The node Link as the hub uses it: send (counted, after what is queued), queue, flush."""

    def __init__(self) -> None:
        self.sent: list = []
        self.pending: list = []
        self.stats = type("S", (), {"tx_packets": 0})()

    def queue(self, m) -> None:
        self.pending.append(m)

    def flush(self) -> None:
        self.sent += self.pending
        self.stats.tx_packets += len(self.pending)
        self.pending.clear()

    def send(self, m) -> None:
        self.flush()
        self.sent.append(m)
        self.stats.tx_packets += 1

    def ticks(self) -> list[tuple[int, int]]:
        return [(m.time_usec, m.period_usec) for m in self.sent
                if getattr(m, "get_type", lambda: "")() == "TOWERLINK_LOCKSTEP"]


def msg(kind, t=0, round_no=0):
    return tl.MAVLink_towerlink_lockstep_message(t, 0, kind, ls.OTHER, round_no)


def hub(expect=2, wall=None):
    link, logs = FakeLink(), []
    now = wall or [0.0]
    h = NodeLockstep(link, lambda m: m, expect, logs.append, lambda: now[0])
    return h, link, now, logs


def test_the_hub_releases_a_barrier_once_every_node_acked_a_quiet_round():
    h, link, _now, _logs = hub(expect=2)
    released: list[int] = []
    for c in (30, 31):
        h.on_message(255, c, msg(ls.JOIN))
    assert h.hold(40_000, lambda: released.append(40_000)) is True
    assert link.ticks() == [(40_000, 1)]              # round 1, numbered in period_usec
    h.on_message(255, 30, msg(ls.ACK, 40_000, 1))
    assert released == []                             # 31 still owes it
    link.queue(b"a node's transform, republished")    # something new for the nodes meanwhile
    h.on_message(255, 31, msg(ls.ACK, 40_000, 1))
    assert released == [] and link.ticks()[-1] == (40_000, 2)   # so a second round
    h.on_message(255, 30, msg(ls.ACK, 40_000, 1))     # late, from round 1: does not count
    h.on_message(255, 31, msg(ls.ACK, 40_000, 2))
    assert released == []
    h.on_message(255, 30, msg(ls.ACK, 40_000, 2))
    assert released == [40_000] and h.settled == 1


def test_the_hub_waits_for_the_expected_nodes_or_the_join_timeout():
    h, link, now, _logs = hub(expect=2)
    released: list[int] = []
    h.on_message(255, 30, msg(ls.JOIN))
    assert h.hold(0, lambda: released.append(0))
    h.on_message(255, 30, msg(ls.ACK, 0, 1))
    assert released == []                             # one of two joined
    h.on_message(255, 31, msg(ls.JOIN))               # the second comes: it gets the TICK too
    assert link.ticks()[-1] == (0, 1)
    h.on_message(255, 31, msg(ls.ACK, 0, 1))
    h.on_message(255, 30, msg(ls.ACK, 0, 1))
    assert released == []                             # the TICK sent again forces one more round
    h.on_message(255, 30, msg(ls.ACK, 0, 2))
    h.on_message(255, 31, msg(ls.ACK, 0, 2))
    assert released == [0]
    h2, _link, now, _ = hub(expect=3)                 # nobody ever comes: the timeout lets it go
    got: list[int] = []
    assert h2.hold(0, lambda: got.append(0))
    now[0] = JOIN_TIMEOUT + 0.1
    h2.upkeep()
    assert got == [0]
    assert h2.hold(40_000, lambda: got.append(1)) is False    # no nodes, no wait


def test_a_node_that_leaves_or_goes_silent_is_not_waited_for():
    h, _link, now, logs = hub(expect=2)
    out: list[int] = []
    for c in (30, 31):
        h.on_message(255, c, msg(ls.JOIN))
    h.hold(0, lambda: out.append(0))
    h.on_message(255, 30, msg(ls.LEAVE))              # its process ended: LEAVE (Node.close, atexit)
    h.on_message(255, 31, msg(ls.ACK, 0, 1))
    assert out == [0]
    h.hold(40_000, lambda: out.append(1))
    now[0] = SILENT_AFTER + 1                         # 31 owes an ACK and says nothing
    h.upkeep()
    assert out == [0, 1] and h.dropped == 1 and any("silent" in line for line in logs)


def test_the_desk_acks_the_world_only_after_the_nodes_settled():
    class VLink:
        def __init__(self):
            self.sent = []

        def send(self, m):
            self.sent.append(m)

    v = type("V", (), {"name": "drone", "sysid": 1, "link": VLink()})()
    h, nlink, _now, _ = hub(expect=1)
    desk = LockstepDesk({1: v}, lambda m: m, lambda m: None, lambda t: None, lambda s: None,
                        lambda: 0.0, nodes=h)
    desk.on_node(255, 30, msg(ls.JOIN))
    desk.on_vehicle(v, tl.MAVLink_towerlink_lockstep_message(40_000, 0, ls.TICK, ls.WORLD, 40_000))
    acks = lambda: [m.time_usec for m in v.link.sent if m.kind == ls.ACK]   # noqa: E731
    assert acks() == [] and nlink.ticks() == [(40_000, 1)]
    desk.on_vehicle(v, tl.MAVLink_towerlink_lockstep_message(40_000, 0, ls.TICK, ls.WORLD, 40_000))
    # the world asked again: not the held barrier, and no barrier was released before it (an
    # ACK(-1) would not even pack: time_usec is unsigned)
    assert acks() == [] and desk.tick_resends_seen == 1
    desk.on_node(255, 30, msg(ls.ACK, 40_000, 1))
    assert acks() == [40_000] and desk.released_usec == 40_000


# ----------------------------------------------------------------------------- a node on a socket


def test_a_lockstep_node_joins_runs_its_loop_at_each_tick_and_acks_after_what_it_sent():
    port = free_port()
    bridge = mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=250, source_component=191)
    node = Node("lab_probe", f"udpout:127.0.0.1:{port}", lockstep=True, heartbeat=False)
    loop_times: list[float] = []
    callbacks: list[float] = []

    def on_text(m):                            # a callback's send between TICKs waits for the next TICK
        node.send(tl.MAVLink_statustext_message(6, b"from the callback"))
        callbacks.append(node.now())

    node.subscribe("STATUSTEXT", on_text)

    def loop():
        rate = node.rate(10)
        while node.ok():
            loop_times.append(node.now())
            node.send(tl.MAVLink_named_value_float_message(0, b"loop", node.now()))
            rate.sleep()

    th = threading.Thread(target=loop, daemon=True)
    try:
        th.start()

        backlog: list = []

        def recv(kinds, timeout=5.0):
            """The next message of `kinds` in arrival order (others before it are skipped, later kept);
            the node's JOINs, sent until a TICK comes, only when JOIN is asked for."""
            end = time.monotonic() + timeout
            while time.monotonic() < end:
                if not backlog:
                    m = bridge.recv_match(blocking=True, timeout=0.2)
                    if m is not None:
                        backlog.append(m)
                    continue
                m = backlog.pop(0)
                if m.get_type() in kinds and not (m.get_type() == "TOWERLINK_LOCKSTEP" and m.kind == ls.JOIN
                                                   and "JOIN" not in kinds):
                    return m
            raise AssertionError(f"no {kinds}")

        first = recv(("NAMED_VALUE_FLOAT", "TOWERLINK_LOCKSTEP"))   # the loop's first pass: sim 0
        assert first.get_type() == "NAMED_VALUE_FLOAT" and first.value == 0.0
        join = recv(("TOWERLINK_LOCKSTEP", "JOIN"))  # once ready (its first ok()): JOIN
        assert join.kind == ls.JOIN and join.participant == ls.OTHER
        bridge.mav.towerlink_lockstep_send(120_000, 0, ls.TICK, ls.BRIDGE, 7)
        got = [recv(("NAMED_VALUE_FLOAT", "TOWERLINK_LOCKSTEP")) for _ in range(2)]
        assert got[0].get_type() == "NAMED_VALUE_FLOAT" and got[0].value == pytest.approx(0.12)
        assert (got[1].kind, got[1].time_usec, got[1].period_usec) == (ls.ACK, 120_000, 7)
        bridge.mav.statustext_send(6, b"to the node")
        wait_until(lambda: callbacks, 5, "the node's STATUSTEXT callback")
        # its send returned before the append: a datagram sent at once would be queued on the
        # bridge's socket by now (loopback); none may be there before the TICK
        early = [m for m in iter(lambda: bridge.recv_match(blocking=False), None)]
        assert [m.get_type() for m in early if m.get_type() == "STATUSTEXT"] == []
        backlog.extend(early)
        bridge.mav.towerlink_lockstep_send(160_000, 0, ls.TICK, ls.BRIDGE, 1)   # not due for the loop
        got = [recv(("STATUSTEXT", "TOWERLINK_LOCKSTEP")) for _ in range(2)]
        assert got[0].get_type() == "STATUSTEXT" and got[1].kind == ls.ACK and got[1].time_usec == 160_000
        assert loop_times == [0.0, 0.12]
    finally:
        node.close()
        th.join(2)
    leave = recv(("TOWERLINK_LOCKSTEP",))
    assert leave.kind == ls.LEAVE
    bridge.close()
