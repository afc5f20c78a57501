"""The pipelined lockstep (`sitl --lockstep-pipeline`): the world sends TICK(t) and steps on at
once, waits for ACK(t) at t + one period, and a participant's reactions to TICK(t) take effect
there -- one period later than without it, at a sim time the data fixes (the gate, pure, and a
world held over UDP; tests/test_lockstep.py has the handshake without pipelining, and both for
when a participant's packets take effect; the full-system proof of determinism is
tests/test_system_lockstep.py)."""
from __future__ import annotations

import math
import socket

import pytest

from common.mavlink import lockstep as L
from common.mavlink.dialect import towerlink as tl
from tests.support import wait_until
from tests.test_lockstep import msg, start_world as start_lockstep_world
from vehicle.lockstep import LockstepGate

P = 40000       # the period, sim us


# ----------------------------------------------------------------------------- the gate (pure)


def test_the_world_waits_at_each_boundary_for_the_acks_of_the_tick_before():
    assert LockstepGate(1, period_usec=P, lag=1).awaited(3 * P) == 2 * P
    assert LockstepGate(1, period_usec=P, lag=0).awaited(3 * P) == 3 * P
    g = LockstepGate(1, period_usec=P, lag=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    assert g.passed(g.awaited(0))               # TICK(0) goes out and the world steps on at once
    assert not g.passed(g.awaited(P))           # at 40 ms it waits for ACK(0)
    g.on_message(msg(L.ACK, 0), 0, "a", 0.1)
    assert g.passed(g.awaited(P)) and not g.passed(g.awaited(2 * P))


def test_a_participants_packet_is_due_two_periods_after_its_newest_ack():
    """Sent after ACK(a): the reaction to TICK(a + period), due at a + 2 periods pipelined
    (a + 1 without); before any ACK at one period (at 0 without)."""
    for lag in (0, 1):
        g = LockstepGate(1, period_usec=P, lag=lag)
        g.on_message(msg(L.JOIN), 0, "a", 0.0)
        assert g.due(250, 191, 0) == lag * P
        g.on_message(msg(L.ACK, 0), 0, "a", 0.1)
        assert g.due(250, 191, 0) == (1 + lag) * P
        g.on_message(msg(L.ACK, 5 * P), 0, "a", 0.2)
        assert g.due(250, 191, 0) == (6 + lag) * P
        assert g.due(1, 190, 0) is None          # anyone else: on arrival
    g = LockstepGate(1, period_usec=P, lag=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    g.on_message(msg(L.ACK, 2 * P), 0, "a", 0.1)
    assert g.holds(250, 191, 0, 3 * P) and not g.holds(250, 191, 0, 4 * P) and g.holds(250, 191, 0, None)


def test_another_system_behind_a_participants_address_is_in_order_with_its_acks():
    """A tf2 node's goal comes through the bridge's socket with the node's ids: pipelined, it is
    the bridge's (and the tower's: the least ACK on that address); without pipelining, and
    from an address no participant joined from, it is handled on arrival as before."""
    tower = dict(sysid=255, compid=190, who=L.TOWER)
    for lag, want in ((1, 3 * P), (0, None)):
        g = LockstepGate(1, period_usec=P, lag=lag)
        g.on_message(msg(L.JOIN), 0, "bridge", 0.0)
        g.on_message(msg(L.JOIN, **tower), 0, "bridge", 0.0)
        g.on_message(msg(L.ACK, 2 * P), 0, "bridge", 0.1)
        g.on_message(msg(L.ACK, P, **tower), 0, "bridge", 0.1)
        assert g.due(7, 42, 0, "bridge") == want
        assert g.due(7, 42, 0, "elsewhere") is None


def test_a_participant_joining_a_pipelined_world_is_waited_for_from_the_next_tick():
    g = LockstepGate(vehicles=1, expect=1, period_usec=P, lag=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    g.on_message(msg(L.ACK, 9 * P), 0, "a", 0.1)
    # the tower joins while TICK(10) is the newest sent: the world at 11 does not wait for it
    g.on_message(msg(L.JOIN, sysid=255, compid=190, who=L.TOWER), 0, "a", 0.2, now_usec=10 * P)
    g.on_message(msg(L.ACK, 10 * P), 0, "a", 0.3)
    assert g.passed(g.awaited(11 * P)) and not g.passed(g.awaited(12 * P))
    assert g.due(255, 190, 0) == 12 * P
    g.on_message(msg(L.LEAVE, sysid=255, compid=190, who=L.TOWER), 0, "a", 0.4)
    assert g.due(255, 190, 0) is None


# ----------------------------------------------------------------------------- a world held over UDP


def start_world(speedup: float = math.inf, timeout: float = 1.0):
    return start_lockstep_world(speedup, timeout, pipeline=True)


def test_the_world_steps_one_frame_past_a_tick_and_waits_there_for_its_ack():
    w, p = start_world()
    try:
        p.send(L.JOIN)
        assert p.next_tick() == 0
        n = w.lockstep.frame_steps
        wait_until(lambda: w.lockstep.waits >= 1, 5.0, "the world waiting for ACK(0) at 40 ms")
        assert w.steps == n                     # stepped on after TICK(0), held at the next TICK
        p.sock.settimeout(0.3)
        with pytest.raises(socket.timeout):     # TICK(40 ms) only once ACK(0) came
            p.next_tick()
        p.sock.settimeout(5.0)
        for k in range(5):
            p.send(L.ACK, k * P)
            assert p.next_tick() == (k + 1) * P
            wait_until(lambda: w.lockstep.waits >= k + 2, 5.0, f"the world waiting for ACK({k + 1})")
            assert w.steps == (k + 2) * n       # one frame ahead of the newest ACK, no further
        assert "pipelined" in w.lockstep.stats_line()
    finally:
        p.close()
        w.stop()


def test_a_tick_is_marked_pipelined_and_one_still_owed_is_sent_again():
    w, p = start_world(timeout=30.0)
    try:
        p.send(L.JOIN)
        m = None
        while m is None:
            m, _rest = L.unpack(p.sock.recvfrom(65535)[0])
        assert (m.kind, m.time_usec, m.lag) == (L.TICK, 0, 1)
        assert p.next_tick() == 0               # no ACK(0): sent again after half a second
        assert w.lockstep.tick_resends >= 1 and w.steps == w.lockstep.frame_steps
        p.send(L.ACK, 0)
        assert p.next_tick() == P
    finally:
        p.close()
        w.stop()


def test_a_silent_participant_is_dropped_and_the_pipelined_world_goes_on(capsys):
    w, p = start_world(timeout=1.0)
    try:
        p.send(L.JOIN)
        assert p.next_tick() == 0
        wait_until(lambda: w.t > 1.0, 10.0, "the world going on without the silent participant")
        assert w.lockstep.gate.dropped == 1
        assert "silent for 1 s (wall): dropped, the world goes on" in capsys.readouterr().out
    finally:
        p.close()
        w.stop()


def test_sitl_refuses_a_pipeline_without_lockstep(capsys):
    from vehicle import cli as sitl_cli
    import argparse
    parser = argparse.ArgumentParser()
    sitl_cli.add_arguments(parser)
    assert sitl_cli.run(parser.parse_args(["--lockstep-pipeline"])) == 2
    assert "--lockstep-pipeline needs --lockstep N" in capsys.readouterr().err
    assert sitl_cli.config_from_args(parser.parse_args(["--lockstep", "2", "--lockstep-pipeline"])).lockstep_pipeline


# ----------------------------------------------------------------------------- the bridge's hold (pure)


def _desk(sent, wall):
    from types import SimpleNamespace

    from bridge.frame_hold import FrameHold
    from bridge.lockstep_desk import LockstepDesk

    class FakeLink:
        def __init__(self, name):
            self.name = name

        def send(self, data):
            sent.append((self.name, data.kind, data.time_usec))

    vehicles = {1: SimpleNamespace(name="drone", sysid=1, link=FakeLink("drone")),
                2: SimpleNamespace(name="rover", sysid=2, link=FakeLink("rover"))}
    handled = []
    desk = LockstepDesk(vehicles, lambda m: m, lambda m: sent.append(("tower", m.kind, m.time_usec, m.lag)),
                        lambda t: None, lambda line: sent.append(("log", line)), lambda: wall[0],
                        on_free=lambda: hold.release())
    by_link = {v.link: v for v in vehicles.values()}
    lag = [1]

    def handle(link, pkt):
        """What VehicleSide.handle does with a TICK (an int here); anything else is noted as handled."""
        if isinstance(pkt, int):
            desk.on_vehicle(by_link[link], tl.MAVLink_towerlink_lockstep_message(pkt, 0, L.TICK, L.WORLD, P, lag[0]))
        else:
            handled.append((link.name, pkt))
    hold = FrameHold([v.link for v in vehicles.values()], handle, lambda pkt: pkt if isinstance(pkt, int) else None,
                     lambda: desk.lag > 0, desk.frame_ready)

    def arrive(v, pkt):                 # VehicleSide.on_packet: held, or handled
        link = vehicles[v].link
        if not hold.take(link, pkt):
            handle(link, pkt)
    return desk, hold, arrive, handled, lag


def _ack(t):
    return tl.MAVLink_towerlink_lockstep_message(t, 0, L.ACK, L.TOWER, 0)


def test_the_bridge_handles_a_pipelined_frame_whole_once_the_tower_acted_on_the_one_before():
    """Pipelined: the packets wait until a frame is complete on both links (each one's TICK in)
    and the tower ACKed the barrier before it (its goals translated against the tree as it stood
    there); then the frame is handled link by link (drone, then rover, whatever the order they
    came in), up to each link's TICK."""
    sent, wall = [], [0.0]
    desk, hold, arrive, handled, _lag = _desk(sent, wall)
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    arrive(1, "d0")                     # before any TICK: handled as it comes
    arrive(1, P)                        # the first TICK says lag 1: from here on packets wait
    arrive(2, "r0")
    arrive(1, "d1")
    arrive(1, 2 * P)
    arrive(1, "d2")
    assert handled == [("drone", "d0")]
    arrive(2, P)                        # frame 40 ms complete: the rover's part, then the barrier
    assert handled == [("drone", "d0"), ("rover", "r0")]
    assert [m for m in sent if m[0] != "log"] == \
        [("drone", L.ACK, P), ("rover", L.ACK, P), ("tower", L.TICK, P, 1)]
    arrive(2, "r1")
    desk.on_tower(_ack(P))
    desk.tower_done()
    assert handled[2:] == []            # the tower acted, but the rover's frame 80 ms is not complete
    arrive(2, 2 * P)
    assert handled[2:] == [("drone", "d1"), ("rover", "r1")] and desk.barrier_usec == 2 * P
    assert hold.waiting() == 1          # d2, behind the drone's TICK(80 ms), waits for the next frame
    desk.on_tower(_ack(2 * P))
    desk.tower_done()
    assert hold.waiting() == 1 and hold.held == 7


def test_a_tick_the_world_sends_again_is_answered_at_once():
    sent, wall = [], [0.0]
    desk, hold, arrive, handled, _lag = _desk(sent, wall)
    arrive(1, P)
    arrive(2, P)
    arrive(1, "d1")
    sent.clear()
    arrive(1, P)                        # TICK(40 ms) again: our ACK was lost
    assert [m for m in sent if m[0] != "log"] == [("drone", L.ACK, P)] and hold.waiting() == 1


def test_a_tick_sent_again_while_its_frame_still_waits_is_no_barrier():
    """The bridge did not run for half a second: the world has sent TICK(80 ms) again behind the
    next frame, and the bridge reads the rover's socket, the TICK sent again included, before
    the drone's. The TICK sent again counts for nothing: else the rover would count as at 80 ms,
    and the drone's TICK(80 ms), handled first, would make the barrier and ACK it before the
    rover's packets of that frame were handled."""
    sent, wall = [], [0.0]
    desk, hold, arrive, handled, _lag = _desk(sent, wall)
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    arrive(1, P)
    arrive(2, P)
    desk.on_tower(_ack(P))
    desk.tower_done()
    sent.clear()
    for pkt in ("r2", 2 * P, "r3", 2 * P):      # the rover's socket: frame 80 ms, 120 ms, TICK(80 ms) again
        arrive(2, pkt)
    assert handled == [] and sent == []
    arrive(1, "d2")
    arrive(1, 2 * P)
    assert handled == [("drone", "d2"), ("rover", "r2")] and desk.barrier_usec == 2 * P
    assert [m for m in sent if m[0] != "log"] == \
        [("drone", L.ACK, 2 * P), ("rover", L.ACK, 2 * P), ("tower", L.TICK, 2 * P, 1)]
    assert hold.waiting() == 1          # r3 waits for the next frame


def test_without_pipelining_the_bridge_holds_nothing():
    sent, wall = [], [0.0]
    desk, hold, arrive, handled, lag = _desk(sent, wall)
    lag[0] = 0
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    arrive(1, P)
    arrive(1, "d1")
    assert handled == [("drone", "d1")] and hold.held == 0


def test_a_silent_tower_is_no_longer_waited_for():
    from bridge.lockstep_desk import TOWER_SILENT
    sent, wall = [], [0.0]
    desk, _hold, arrive, handled, _lag = _desk(sent, wall)
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    arrive(1, P)
    arrive(2, P)
    arrive(1, "d1")
    arrive(1, 2 * P)
    arrive(2, 2 * P)
    wall[0] = TOWER_SILENT - 0.1
    desk.upkeep(wall[0])
    assert handled == [] and desk.tower_joined
    wall[0] = TOWER_SILENT + 0.1
    desk.upkeep(wall[0])
    assert handled == [("drone", "d1")] and not desk.tower_joined
    assert any("silent" in m[1] for m in sent if m[0] == "log")
