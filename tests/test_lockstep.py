"""Whole-system lockstep (issue 11): the TOWERLINK_LOCKSTEP message, the world's gate, and a
world held by a participant over a real UDP socket (the full-system proof is in
tests/test_system_lockstep.py)."""
from __future__ import annotations

import math
import socket
from types import SimpleNamespace

import pytest
from hypothesis import given, strategies as st

from common.mavlink import lockstep as L
from common.mavlink.dialect import towerlink as tl
from tests.support import free_port, udp_listener, wait_until
from vehicle.lockstep import LockstepGate
from vehicle.world import World, WorldConfig


# ----------------------------------------------------------------------------- the wire


@given(kind=st.sampled_from([L.JOIN, L.ACK, L.TICK, L.LEAVE]), t=st.integers(0, 2**64 - 1),
       who=st.integers(0, 3), target=st.integers(0, 255), period=st.integers(0, 2**32 - 1),
       sysid=st.integers(1, 255), compid=st.integers(0, 255), seq=st.integers(0, 255),
       lag=st.integers(0, 255))
def test_pack_is_the_dialect_bytes_and_unpacks(kind, t, who, target, period, sysid, compid, seq, lag):
    mav = tl.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq
    ref = tl.MAVLink_towerlink_lockstep_message(t, target, kind, who, period, lag).pack(mav)
    mine = L.pack(kind, t, participant=who, target_system=target, period_usec=period,
                  sysid=sysid, compid=compid, seq=seq, lag=lag)
    assert mine == ref
    m, rest = L.unpack(ref + b"tail")
    assert rest == b"tail"
    assert (m.kind, m.time_usec, m.participant, m.target_system, m.period_usec, m.sysid, m.compid, m.lag) == \
        (kind, t, who, target, period, sysid, compid, lag)
    assert L.read_checked(ref) == m     # a frame already cut and checked: read without the CRC
    mav.seq = seq       # lag 0 (the extension trimmed): the bytes of the message without the field
    assert L.pack(kind, t, participant=who, target_system=target, period_usec=period, sysid=sysid,
                  compid=compid, seq=seq) == tl.MAVLink_towerlink_lockstep_message(t, target, kind, who, period).pack(mav)


def test_crc_extra_and_id_match_the_dialect():
    assert L.CRC_EXTRA == tl.MAVLink_towerlink_lockstep_message.crc_extra
    assert L.MSG_ID == tl.MAVLINK_MSG_ID_TOWERLINK_LOCKSTEP
    assert (L.JOIN, L.ACK, L.TICK, L.LEAVE) == (tl.TOWERLINK_LOCKSTEP_KIND_JOIN, tl.TOWERLINK_LOCKSTEP_KIND_ACK,
                                                tl.TOWERLINK_LOCKSTEP_KIND_TICK, tl.TOWERLINK_LOCKSTEP_KIND_LEAVE)


def test_other_packets_and_damaged_frames_pass_through_untouched():
    hb = tl.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(tl.MAVLink(None, 255, 190))
    assert L.unpack(hb) == (None, hb)
    assert L.read_checked(hb) is None
    good = L.pack(L.ACK, 40000, sysid=250, compid=191)
    bad = good[:-1] + bytes([good[-1] ^ 0xFF])
    assert L.unpack(bad) == (None, bad)
    assert L.unpack(good[:12]) == (None, good[:12])


def test_speedup_arg():
    assert L.speedup_arg("max") == math.inf and L.speedup_arg(" MAX ") == math.inf
    assert L.speedup_arg("2.5") == 2.5
    for bad in ("0", "-1", "nan", "fast"):
        with pytest.raises(ValueError):
            L.speedup_arg(bad)
    assert L.speedup_text(math.inf) == "max" and L.speedup_text(8.0) == "8"


# ----------------------------------------------------------------------------- the gate (pure)


def msg(kind, t_usec=0, sysid=250, compid=191, who=L.BRIDGE):
    return L.Lockstep(t_usec, kind, who, 0, 0, sysid, compid)


def test_gate_starts_when_the_expected_participants_joined_on_every_vehicle():
    g = LockstepGate(vehicles=2, expect=2, timeout=10.0)
    assert not g.started(0.0)
    assert g.on_message(msg(L.JOIN), 0, "a", 0.0) == "lockstep: bridge (sysid 250, compid 191) joined"
    g.on_message(msg(L.JOIN), 1, "b", 0.1)
    g.on_message(msg(L.JOIN, sysid=255, compid=190, who=L.TOWER), 0, "a", 0.2)
    assert not g.started(0.3)                   # the tower is on vehicle 0 only so far
    g.on_message(msg(L.JOIN, sysid=255, compid=190, who=L.TOWER), 1, "b", 0.4)
    assert g.started(0.5)
    assert g.channels(0) == ["a"] and g.channels(1) == ["b"]    # one TICK per channel


def test_a_join_naming_one_vehicle_counts_for_that_vehicle_alone():
    # the van's driver talks to the van's own endpoint only: its JOIN names the van (sysid 3)
    g = LockstepGate(vehicles=3, expect=2, timeout=10.0)
    for i, ch in enumerate("abc"):
        g.on_message(msg(L.JOIN), i, ch, 0.0)                     # the bridge, on every vehicle
    van = L.Lockstep(0, L.JOIN, L.OTHER, 3, 0, 255, 200)
    g.on_message(L.Lockstep(0, L.JOIN, L.OTHER, 0, 0, 255, 201), 2, "v", 0.1)   # names none
    assert not g.started(0.2)                   # a one-link participant naming no vehicle is not full
    g.on_message(van, 2, "v", 0.3)
    assert g.started(0.3)
    assert g.channels(2) == ["c", "v"] and g.channels(0) == ["a"]
    g.on_message(msg(L.ACK, 40000), 0, "a", 0.4)
    g.on_message(msg(L.ACK, 40000), 1, "b", 0.4)
    g.on_message(msg(L.ACK, 40000), 2, "c", 0.4)
    g.on_message(L.Lockstep(40000, L.ACK, L.OTHER, 0, 0, 255, 201), 2, "v", 0.4)
    assert not g.passed(40000)                  # the van's driver owes its ACK on the van's link
    g.on_message(L.Lockstep(40000, L.ACK, L.OTHER, 3, 0, 255, 200), 2, "v", 0.5)
    assert g.passed(40000)


def test_gate_starts_anyway_after_the_timeout_with_whoever_joined():
    g = LockstepGate(vehicles=2, expect=2, timeout=5.0)
    g.on_message(msg(L.JOIN), 0, "a", 100.0)
    assert not g.started(104.9)
    assert g.started(105.0)


def test_gate_waits_for_an_ack_on_every_link_a_participant_joined_on():
    g = LockstepGate(vehicles=2, expect=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    g.on_message(msg(L.JOIN), 1, "b", 0.0)
    assert not g.passed(0)
    g.on_message(msg(L.ACK, 40000), 0, "a", 0.1)
    assert not g.passed(40000)                  # vehicle 1's link may still carry a reaction
    g.on_message(msg(L.ACK, 40000), 1, "b", 0.1)
    assert g.passed(40000) and not g.passed(80000)
    g.on_message(msg(L.ACK, 20000), 1, "b", 0.2)  # an old ACK never moves it back
    assert g.passed(40000)


def test_gate_drops_a_silent_participant_and_a_leaving_one():
    g = LockstepGate(vehicles=1, expect=1, timeout=2.0)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    g.on_message(msg(L.JOIN, sysid=255, compid=190, who=L.TOWER), 0, "a", 0.0)
    g.on_message(msg(L.ACK, 40000), 0, "a", 1.0)
    assert g.drop_silent(1.9, 40000) == []
    gone = g.drop_silent(2.0, 40000)            # the tower owes ACK(40000) and was silent 2 s
    assert [p.sysid for p in gone] == [255] and g.dropped == 1 and g.passed(40000)
    assert g.on_message(msg(L.LEAVE), 0, "a", 3.0) == "lockstep: bridge (sysid 250, compid 191) left"
    assert g.participants == {} and g.passed(10**12)


def test_a_participant_joining_a_running_world_is_waited_for_from_the_next_tick():
    g = LockstepGate(vehicles=1, expect=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    assert g.started(0.0)
    g.on_message(msg(L.ACK, 400000), 0, "a", 1.0)
    # the tower comes back after being dropped; TICK(400 ms) went out before it joined
    g.on_message(msg(L.JOIN, sysid=255, compid=190, who=L.TOWER), 0, "a", 1.1, now_usec=400000)
    assert g.passed(400000) and not g.passed(440000)
    g.on_message(msg(L.ACK, 440000), 0, "a", 1.2)
    assert not g.passed(440000)                 # the tower owes ACK(440 ms) now
    g.on_message(msg(L.ACK, 440000, sysid=255, compid=190, who=L.TOWER), 0, "a", 1.3)
    assert g.passed(440000)


def test_gate_holds_a_participants_packets_to_the_next_boundary_once_it_acked():
    g = LockstepGate(vehicles=1, expect=1)
    g.on_message(msg(L.JOIN), 0, "a", 0.0)
    assert not g.holds(250, 191, 0, 40000)       # at TICK(40 ms), not yet ACKed: handled now
    assert g.holds(250, 191, 0, None)            # between TICKs: the next boundary
    g.on_message(msg(L.ACK, 40000), 0, "a", 0.1)
    assert g.holds(250, 191, 0, 40000)           # after its ACK(40 ms): belongs to the next frame
    assert not g.holds(1, 190, 0, None)          # anyone else: an ordinary vehicle, on arrival


# ----------------------------------------------------------------------------- a world held over UDP


class Participant:
    """A raw UDP lockstep participant of vehicle 0's udpin endpoint."""

    def __init__(self, port: int, sysid: int = 250, compid: int = 191) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(5.0)
        self.addr = ("127.0.0.1", port)
        self.sysid, self.compid = sysid, compid
        self.parser = tl.MAVLink(None)
        self.parser.robust_parsing = True

    def send(self, kind: int, t_usec: int = 0) -> None:
        self.sock.sendto(L.pack(kind, t_usec, participant=L.BRIDGE, sysid=self.sysid, compid=self.compid),
                         self.addr)

    def next_tick(self) -> int:
        """time_usec of the next TICK (other messages are skipped)."""
        while True:
            data, _ = self.sock.recvfrom(65535)
            for m in self.parser.parse_buffer(data) or []:
                if m.get_type() == "TOWERLINK_LOCKSTEP" and m.kind == L.TICK:
                    return m.time_usec

    def close(self) -> None:
        self.sock.close()


    def messages_until_tick(self) -> tuple[list, int]:
        """(messages before the next TICK, that TICK's time_usec)."""
        out = []
        while True:
            data, _ = self.sock.recvfrom(65535)
            for m in self.parser.parse_buffer(data) or []:
                if m.get_type() == "TOWERLINK_LOCKSTEP" and m.kind == L.TICK:
                    return out, m.time_usec
                out.append(m)

    def request_system_time(self) -> None:
        mav = tl.MAVLink(None, srcSystem=self.sysid, srcComponent=self.compid)
        self.sock.sendto(tl.MAVLink_command_long_message(1, 1, tl.MAV_CMD_REQUEST_MESSAGE, 0,
                                                         tl.MAVLINK_MSG_ID_SYSTEM_TIME, 0, 0, 0, 0, 0, 0).pack(mav),
                         self.addr)


def start_world(speedup: float = math.inf, timeout: float = 1.0, pipeline: bool = False):
    port = free_port()
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None, speedup=speedup,
                          endpoints={0: [f"udpin:127.0.0.1:{port}"]}, lockstep=1, lockstep_period=0.04,
                          lockstep_timeout=timeout, lockstep_pipeline=pipeline))
    w.start_thread()
    return w, Participant(port)


@pytest.fixture
def held_world():
    w, p = start_world()
    try:
        yield w, p
    finally:
        p.close()
        w.stop()


def test_world_never_steps_past_an_unacknowledged_tick(held_world):
    w, p = held_world
    assert w.t == 0.0
    p.send(L.JOIN)
    assert p.next_tick() == 0
    wait_until(lambda: w.lockstep.waits >= 1, 5.0, "the world waiting for ACK(0)")
    assert w.steps == 0                        # --speedup max, yet held at t = 0
    for k in range(5):
        p.send(L.ACK, k * 40000)
        assert p.next_tick() == (k + 1) * 40000
        wait_until(lambda: w.lockstep.waits >= k + 2, 5.0, f"the world waiting for ACK({k + 1})")
        assert w.steps == (k + 1) * w.lockstep.frame_steps     # exactly at the TICK, not one step further
    assert w.lockstep.frame_steps * w.dt == pytest.approx(0.04)


def test_a_tick_still_owed_an_ack_is_sent_again_and_a_rejoining_participant_is_not_silent():
    """A TICK or an ACK lost on a vehicle link: the world sends the TICK again to whoever owes
    the ACK, each TICK_RESEND wall s; the participant ACKs, the world goes on. (Without the
    resend the world stood forever: a bridge with no TICK JOINs again, so it is never silent.)"""
    w, p = start_world(timeout=30.0)
    try:
        p.send(L.JOIN)
        assert p.next_tick() == 0
        p.send(L.ACK, 0)
        assert p.next_tick() == 40000           # ... and "lost": no ACK
        p.send(L.JOIN)                          # what a bridge does after a second with no TICK
        assert p.next_tick() == 40000           # sent again
        assert w.lockstep.tick_resends >= 1 and w.steps == w.lockstep.frame_steps
        p.send(L.ACK, 40000)
        assert p.next_tick() == 80000
        assert w.lockstep.gate.dropped == 0 and "TICK(s) sent again" in w.lockstep.stats_line()
    finally:
        p.close()
        w.stop()


def test_gate_owes_a_tick_where_an_ack_is_missing():
    g = LockstepGate(vehicles=2, expect=1)
    tower = dict(sysid=255, compid=190, who=L.TOWER)
    for v, ch in ((0, "b0"), (1, "b1")):
        g.on_message(msg(L.JOIN), v, ch, 0.0)
        g.on_message(msg(L.JOIN, **tower), v, ch, 0.0)    # the tower, through the bridge's channel
    g.on_message(msg(L.ACK, 40000), 0, "b0", 0.1)
    g.on_message(msg(L.ACK, 40000), 1, "b1", 0.1)
    g.on_message(msg(L.ACK, 40000, **tower), 0, "b0", 0.1)
    assert g.owed(40000) == [(1, "b1")]                   # the tower's ACK via vehicle 1 is missing
    g.on_message(msg(L.ACK, 40000, **tower), 1, "b1", 0.2)
    assert g.owed(40000) == [] and g.passed(40000)


def test_a_silent_participant_is_dropped_and_the_world_goes_on(held_world, capsys):
    w, p = held_world
    p.send(L.JOIN)
    assert p.next_tick() == 0
    wait_until(lambda: w.t > 1.0, 10.0, "the world going on without the silent participant")
    assert w.lockstep.gate.dropped == 1
    assert "lockstep: bridge (sysid 250, compid 191) silent for 1 s (wall): dropped, the world goes on" \
        in capsys.readouterr().out


def test_a_closing_bridge_leaves_and_the_world_goes_on_at_once(capsys):
    """The bridge says LEAVE when it closes: a world with a 60 s --lockstep-timeout goes on
    without waiting for it (a world started by hand, the bridge stopped or restarted)."""
    from bridge_fakes import bridge_config, running_bridge
    w, p = start_world(timeout=60.0)
    try:
        cfg = bridge_config(free_port(), None, None, lockstep=True, follow=False)
        cfg.drone = f"udpout:127.0.0.1:{p.addr[1]}"
        with running_bridge(cfg) as bridge:
            wait_until(lambda: w.t >= 0.4, 10.0, "the world stepping with the bridge acking")
            assert bridge.lockstep.barriers >= 10
        t_left = w.t
        wait_until(lambda: w.t > t_left + 2.0, 10.0, "the world going on after the bridge left")
        assert w.lockstep.gate.dropped == 0 and not w.lockstep.gate.participants
        assert "lockstep: bridge (sysid 250, compid 191) left" in capsys.readouterr().out
    finally:
        p.close()
        w.stop()


@pytest.mark.parametrize("lag", [0, 1])
@pytest.mark.parametrize("speedup", [math.inf, 20.0])
def test_a_participants_packets_take_effect_at_a_tick_boundary(speedup, lag):
    """Sent before its ACK(t): handled at t. Sent after it: at the next TICK, t + 40 ms, never
    in between, whenever the machine delivered it (paced at 20x the world sleeps mid-frame).
    (The answer to a packet sent after the ACK may come before or after that next TICK: a
    participant's reactions go before its ACK, so their answers come before the next TICK.)
    Pipelined (lag 1, tests/test_lockstep_pipeline.py) each one TICK later: t + 40 ms, t + 80 ms."""
    w, p = start_world(speedup, pipeline=bool(lag))
    try:
        p.send(L.JOIN)
        t = p.next_tick()
        sent_at, msgs = [], []
        for _ in range(12):
            p.request_system_time()
            p.send(L.ACK, t)
            p.request_system_time()
            sent_at += [t // 1000 + 40 * lag, t // 1000 + 40 + 40 * lag]
            before, nxt = p.messages_until_tick()
            msgs += before
            assert nxt == t + 40000
            t = nxt
        p.send(L.ACK, t)
        msgs += p.messages_until_tick()[0]
        replies = [msgs[i + 1].time_boot_ms for i, m in enumerate(msgs[:-1])
                   if m.get_type() == "COMMAND_ACK" and m.command == tl.MAV_CMD_REQUEST_MESSAGE]
        assert replies == sent_at
    finally:
        p.close()
        w.stop()


def test_a_third_party_client_sees_an_ordinary_vehicle_beside_a_participant(held_world):
    """A pymavlink GCS (ardupilotmega, no towerlink dialect) gets heartbeats from the held world
    and never a TOWERLINK_LOCKSTEP (it would not decode it)."""
    from pymavlink import mavutil
    w, p = held_world
    port = p.addr[1]
    p.send(L.JOIN)
    t = p.next_tick()
    gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=254, dialect="ardupilotmega")
    try:
        gcs.mav.heartbeat_send(6, 8, 0, 0, 4)
        seen: list = []
        while w.t < 2.5:                         # the participant keeps the world going
            p.send(L.ACK, t)
            t = p.next_tick()
            while (m := gcs.recv_match(blocking=False)) is not None:
                seen.append(m)
        while (m := gcs.recv_match(blocking=True, timeout=0.5)) is not None:
            seen.append(m)
        types = {m.get_type() for m in seen}
        assert "HEARTBEAT" in types and "ATTITUDE" in types
        assert not types & {"BAD_DATA", "UNKNOWN_43005", "TOWERLINK_LOCKSTEP"}
        assert all(m.get_msgId() != L.MSG_ID for m in seen)
    finally:
        gcs.close()


# ----------------------------------------------------------------------------- the tower's client


def test_lockstep_client_acts_only_at_ticks_and_acks_after_its_reactions():
    """gcs.client.Client(lockstep=True) as the tower uses it, against a fake bridge on UDP."""
    import threading

    from gcs.client import Client
    bridge, port = udp_listener(5.0)
    parser = tl.MAVLink(None)
    enc = tl.MAVLink(None, srcSystem=250, srcComponent=191)
    vehicle = tl.MAVLink(None, srcSystem=1, srcComponent=1)

    def received(until):
        """Messages from the client up to and including the first one `until` accepts."""
        out = []
        while True:
            data, addr = bridge.recvfrom(65535)
            for m in parser.parse_buffer(data) or []:
                out.append(m)
                if until(m):
                    return out, addr

    def lockstep(kind):
        return lambda m: m.get_type() == "TOWERLINK_LOCKSTEP" and m.kind == kind

    def tick(t_usec):
        return tl.MAVLink_towerlink_lockstep_message(t_usec, 0, L.TICK, L.WORLD, 40000).pack(enc)

    c = Client.connect(f"udpout:127.0.0.1:{port}", lockstep=True)
    try:
        joins, addr = received(lockstep(L.JOIN))
        assert joins[-1].participant == L.TOWER and joins[-1].target_system == 0
        bridge.sendto(tick(0), addr)
        c.poll(0.0)
        assert c.tick_usec == 0
        c.goto(1.0, 2.0, -3.0)                 # the program's reaction to TICK(0)
        done = []
        th = threading.Thread(target=lambda: done.append(c.poll(0.0)), daemon=True)
        th.start()
        msgs, _ = received(lockstep(L.ACK))
        types = [m.get_type() for m in msgs]
        assert "SET_POSITION_TARGET_LOCAL_NED" in types
        assert types.index("SET_POSITION_TARGET_LOCAL_NED") < len(types) - 1 and msgs[-1].time_usec == 0
        bridge.sendto(tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(vehicle), addr)
        wait_until(lambda: c.system(1).heartbeat_wall is not None, 5.0, "the vehicle heartbeat handled")
        assert th.is_alive() and not done         # a poll returns at a TICK, not at any message
        bridge.sendto(tick(40000), addr)
        th.join(5.0)
        assert done and c.tick_usec == 40000 and c.sim_time(1) == 0.0
        assert c.system(1).heartbeat_wall == pytest.approx(1e-6)   # noted just after TICK(0)
    finally:
        c.close()
    leave, _ = received(lockstep(L.LEAVE))
    assert leave[-1].time_usec == 40000
    bridge.close()


# ----------------------------------------------------------------------------- the bridge's desk


def test_bridge_desk_sends_an_unacknowledged_tick_to_the_tower_again():
    """A TICK or the tower's ACK lost in a burst (100 drones) must not stall the world."""
    from types import SimpleNamespace

    from bridge.lockstep_desk import TICK_RESEND, LockstepDesk
    sent = []
    link = SimpleNamespace(send=lambda data: None)
    vehicles = {1: SimpleNamespace(name="drone", sysid=1, link=link)}
    wall = [0.0]
    desk = LockstepDesk(vehicles, lambda m: m, lambda m: sent.append(m), lambda t: None,
                        lambda line: None, lambda: wall[0])
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    desk.on_vehicle(vehicles[1], tl.MAVLink_towerlink_lockstep_message(40000, 0, L.TICK, L.WORLD, 40000))
    assert [(m.kind, m.time_usec) for m in sent] == [(L.TICK, 40000)]
    wall[0] = TICK_RESEND / 2
    desk.upkeep(wall[0])
    assert len(sent) == 1                      # not yet
    wall[0] = TICK_RESEND + 0.01
    desk.upkeep(wall[0])
    assert [(m.kind, m.time_usec) for m in sent] == [(L.TICK, 40000)] * 2 and desk.tick_resends == 1
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(40000, 0, L.ACK, L.TOWER, 0))
    wall[0] = 5.0
    desk.upkeep(wall[0])
    assert len(sent) == 2                      # ACKed: never again


def test_client_acks_a_repeated_tick_again():
    from gcs.client import Client
    from common.mavlink.lockstep import ACK, TICK

    class Mav:
        def __init__(self):
            self.sent = []

        def towerlink_lockstep_send(self, t_usec, target, kind, who, period):
            self.sent.append((kind, t_usec))

        def heartbeat_send(self, *a):
            pass
    master = SimpleNamespace(mav=Mav(), close=lambda: None)
    c = Client(master, lockstep=True)
    mav = master.mav
    mav.sent.clear()
    msg = tl.MAVLink_towerlink_lockstep_message(40000, 0, TICK, L.WORLD, 40000)
    msg._header = SimpleNamespace(srcSystem=250, srcComponent=191)
    c._handle(msg)                             # a new TICK: ACKed at the next poll, not here
    assert mav.sent == [] and c.ticks.ack_due == 40000 and c.tick_usec == 40000
    c._send_due_ack()                          # what poll does first
    assert mav.sent == [(ACK, 40000)] and c.ticks.ack_due is None
    c._handle(msg)                             # the same TICK again: our ACK was lost
    assert mav.sent == [(ACK, 40000), (ACK, 40000)]


def test_tick_clock_acks_each_tick_once_acted_on_and_a_repeated_one_again():
    """gcs.client.lockstep.TickClock, the client's books of the handshake (pure)."""
    from gcs.client.lockstep import TickClock
    ticks = TickClock()
    assert ticks.now() == 0.0 and ticks.take_ack() is None
    assert ticks.on_tick(40000) is None and ticks.now() == 0.04 and ticks.ack_due == 40000
    assert ticks.on_tick(40000) is None        # again before our ACK went out: nothing to repeat
    assert ticks.take_ack() == 40000 and ticks.take_ack() is None
    assert ticks.on_tick(40000) == 40000       # again after it: our ACK was lost, ACK at once
    assert ticks.on_tick(0) == 40000           # an older one: the newest ACK covers it
    assert ticks.on_tick(80000) is None and ticks.ack_due == 80000
    assert ticks.on_tick(40000) is None        # a late old TICK while 80000 is due: no ACK yet
    assert ticks.now() == 0.08


def test_bridge_desk_barrier_needs_a_tick_on_every_vehicle_link_then_upkeep_ack_and_relay():
    from types import SimpleNamespace

    from bridge.lockstep_desk import LockstepDesk
    sent = []

    class FakeLink:
        def __init__(self, name):
            self.name = name

        def send(self, data):
            sent.append((self.name, data))

    vehicles = {1: SimpleNamespace(name="drone", sysid=1, link=FakeLink("drone")),
                2: SimpleNamespace(name="rover", sysid=2, link=FakeLink("rover"))}
    wall = [0.0]
    desk = LockstepDesk(vehicles, lambda m: m, lambda m: sent.append(("tower", m)),
                        lambda t: sent.append(("upkeep", t)), lambda line: None, lambda: wall[0])

    def tick(t):
        return tl.MAVLink_towerlink_lockstep_message(t, 0, L.TICK, L.WORLD, 40000)

    desk.upkeep(0.0)
    assert [(d, m.kind, m.target_system) for d, m in sent] == [("drone", L.JOIN, 1), ("rover", L.JOIN, 2)]
    sent.clear()
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(0, 0, L.JOIN, L.TOWER, 0))
    desk.on_vehicle(vehicles[1], tick(0))
    assert sent == []                          # the rover link's data up to 0 may still be coming
    desk.on_vehicle(vehicles[2], tick(0))
    assert [(d, m if d == "upkeep" else (m.kind, m.time_usec)) for d, m in sent] == \
        [("upkeep", 0.0), ("drone", (L.ACK, 0)), ("rover", (L.ACK, 0)), ("tower", (L.TICK, 0))]
    assert desk.sim_now == 0.0
    sent.clear()
    desk.on_vehicle(vehicles[2], tick(40000))
    desk.on_vehicle(vehicles[1], tick(40000))
    assert sent[0] == ("upkeep", 0.04) and desk.sim_now == 0.04
    sent.clear()
    wall[0] = 0.5
    desk.on_vehicle(vehicles[2], tick(40000))   # the world sent TICK(40 ms) again: an ACK was lost
    desk.on_vehicle(vehicles[1], tick(40000))   # ... on both links: the tower is TICKed once
    assert [(d, m.kind, m.time_usec) for d, m in sent] == \
        [("rover", L.ACK, 40000), ("tower", L.TICK, 40000), ("drone", L.ACK, 40000)]
    assert desk.barriers == 2 and desk.tick_resends_seen == 2
    sent.clear()
    desk.on_tower(tl.MAVLink_towerlink_lockstep_message(40000, 0, L.ACK, L.TOWER, 0))
    wall[0] = 0.9
    desk.upkeep(0.9)                            # ticking: no JOIN; the tower ACKed: no TICK again
    assert sent == []
    wall[0] = 2.5
    desk.upkeep(2.5)                            # no TICK for over a second: JOIN again
    assert [(d, m.kind) for d, m in sent] == [("drone", L.JOIN), ("rover", L.JOIN)]
    sent.clear()
    desk.leave()                                # closing: the world is told, on every link
    assert [(d, m.kind, m.time_usec, m.target_system) for d, m in sent] == \
        [("drone", L.LEAVE, 40000, 1), ("rover", L.LEAVE, 40000, 2)]


# ----------------------------------------------------------------------------- a world in several processes


@pytest.mark.parametrize("lag", [0, 1])
def test_a_world_in_two_worker_processes_steps_as_one_under_one_participant(processes, lag):
    """`sitl --workers 2 --lockstep 1 --speedup max`: a participant that acts as the bridge
    does (ACK t on every link once TICK(t) came on all of them) holds both workers together;
    a worker whose link is not ACKed stays at its TICK while the other may go one frame on.
    Pipelined (lag 1) each steps one frame past its newest TICK, and no further."""
    ports = [free_port(), free_port()]
    proc = processes.start(["towerlink", "sitl", "--drones", "1", "--rovers", "1", "--workers", "2",
                            "--lockstep", "1", *(["--lockstep-pipeline"] if lag else []),
                            "--speedup", "max", "--no-save", "--tcp-base", "0",
                            "--udp-base", "0", "--lockstep-timeout", "30",
                            *(a for i, p in enumerate(ports) for a in ("--endpoint", f"{i}=udpin:127.0.0.1:{p}"))])
    links = [Participant(p) for p in ports]
    try:
        for link in links:
            link.sock.settimeout(0.3)

        def joined_tick(link) -> int:
            while True:                     # JOIN until the worker's endpoint is up and ticks
                link.send(L.JOIN)
                try:
                    return link.next_tick()
                except socket.timeout:
                    assert proc.poll() is None, proc.stdout.read()
        assert [joined_tick(link) for link in links] == [0, 0]
        for link in links:
            link.sock.settimeout(10.0)
        t = 0
        stamped = [0, 0]
        for _ in range(50):                 # the bridge's barrier: both at t, then ACK both
            for link in links:
                link.send(L.ACK, t)
            seen = [link.messages_until_tick() for link in links]
            assert [tick for _, tick in seen] == [t + 40000] * 2
            for i, (msgs, _) in enumerate(seen):   # nothing a worker sent before TICK(t') is later than t'
                stamps = [m.time_boot_ms for m in msgs if hasattr(m, "time_boot_ms")]
                assert all(s <= (t + 40000) // 1000 for s in stamps)
                stamped[i] += len(stamps)
            t += 40000
        assert min(stamped) > 10            # both workers' vehicles did talk, on their own clocks
        links[0].send(L.ACK, t)             # only worker 0's link: it goes on one frame, no further
        msgs0, tick0 = links[0].messages_until_tick()
        assert tick0 == t + 40000
        links[1].sock.settimeout(0.5)
        late = []
        with pytest.raises(socket.timeout):
            while True:                     # worker 1 stays held at t (pipelined t + 40 ms): nothing newer comes
                data, _ = links[1].sock.recvfrom(65535)
                late += [m for m in links[1].parser.parse_buffer(data) or []
                         if getattr(m, "time_boot_ms", 0) > (t + lag * 40000) // 1000]
        assert late == []
        assert proc.poll() is None
    finally:
        for link in links:
            link.close()


def test_with_a_signing_key_only_a_signed_join_counts_and_the_ticks_are_signed():
    from common.mavlink.signing import SignatureCheck, key_from_text, signing_timestamp
    key = key_from_text("lockstep secret")
    port = free_port()
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None, speedup=math.inf,
                          endpoints={0: [f"udpin:127.0.0.1:{port}"]}, lockstep=1, lockstep_period=0.04,
                          lockstep_timeout=30.0, signing_key=key))
    w.start_thread()
    forger, signer = Participant(port, sysid=251), Participant(port, sysid=250)
    try:
        # unsigned, and signed with another key: neither joins, both are counted as the link counts
        forger.sock.sendto(L.pack(L.JOIN, 0, participant=L.BRIDGE, sysid=251, compid=191), forger.addr)
        forger.sock.sendto(L.pack(L.JOIN, 0, participant=L.BRIDGE, sysid=251, compid=191,
                                  signing=(key_from_text("wrong"), 0, signing_timestamp())), forger.addr)
        stats = w.vehicles[0].link.stats
        wait_until(lambda: stats["unsigned"] >= 1 and stats["bad_signature"] >= 1, 5.0, "both refused")
        assert w.lockstep.gate.participants == {} and w.steps == 0
        signer.sock.sendto(L.pack(L.JOIN, 0, participant=L.BRIDGE, sysid=250, compid=191,
                                  signing=(key, 0, signing_timestamp())), signer.addr)
        while True:
            data, _ = signer.sock.recvfrom(65535)
            m, rest = L.unpack(data)
            if m is not None and m.kind == L.TICK:
                break
        assert m.time_usec == 0 and set(w.lockstep.gate.participants) == {(250, 191)}
        tick = data[:len(data) - len(rest)]
        assert tick[2] & 1 and SignatureCheck(key).check(tick, 1, 1) is None   # signed with the key
    finally:
        forger.close()
        signer.close()
        w.stop()


def test_a_lockstep_client_at_t0_does_not_take_no_heartbeat_for_one():
    # the van's driver asked for AUTO before the van's first heartbeat and got the copter's
    # mode number: with lockstep the clock starts at 0, and "no heartbeat" compared as t = 0
    from gcs.client import Client, ClientError
    world, port = udp_listener(5.0)
    c = Client.connect(f"udpout:127.0.0.1:{port}", lockstep=True, lockstep_target=3, source_component=200)
    c.lockstep_timeout = 0.5
    try:
        parser = tl.MAVLink(None)
        while True:
            data, addr = world.recvfrom(65535)
            ms = [m for m in parser.parse_buffer(data) or [] if m.get_type() == "TOWERLINK_LOCKSTEP"]
            if ms:
                break
        assert (ms[0].kind, ms[0].target_system, ms[0].participant) == (L.JOIN, 3, L.OTHER)
        world.sendto(L.pack(L.TICK, 0, sysid=3), addr)
        c.poll(0.0)
        assert c.tick_usec == 0
        with pytest.raises(ClientError):        # no TICK, no heartbeat: it waits, then times out
            c.wait_heartbeat(3, timeout=1.0)
        assert c.system(3).mav_type is None
    finally:
        c.close()
        world.close()
