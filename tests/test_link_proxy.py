"""The faulty-link UDP proxy (tools.link_proxy) on real sockets: it drops what it says it drops,
lockstep traffic passes untouched, in lockstep it shapes on the TICKs' clock and applies the
fault timeline at the tower's ACKs."""
from __future__ import annotations

import socket

import pytest

from support import free_port, wait_until
from common.link_settings import LinkSettings
from common.mavlink import lockstep as L
from common.scenario_faults import Fault
from tools.fault_timeline import FaultTimeline, ParamSet
from tools.link_frames import Unit
from tools.link_proxy import LinkProxy, bridge_wall_paced


class Ends:
    """A client and an upstream socket around a proxy; closed by close()."""

    def __init__(self, **kw) -> None:
        self.upstream = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.upstream.bind(("127.0.0.1", 0))
        self.upstream.settimeout(2)
        self.client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.client.bind(("127.0.0.1", 0))
        self.client.settimeout(2)
        self.proxy = LinkProxy(free_port(), self.upstream.getsockname(), **kw)
        self.proxy.start()
        self.front = ("127.0.0.1", self.proxy.front.getsockname()[1])
        self.back = self.proxy.back.getsockname()

    def close(self) -> None:
        self.proxy.stop()
        self.upstream.close()
        self.client.close()


def test_drops_about_the_asked_fraction_each_way_and_is_replayable():
    counts = []
    lossy = LinkSettings(loss=0.2)
    for _ in range(2):
        e = Ends(up=lossy, down=lossy, seed=4)
        proxy = e.proxy
        try:
            got = []
            for way, sock, dest in (("up", e.client, e.front), ("down", e.upstream, e.back)):
                # batches small enough for the kernel's socket buffers: nothing lost but by the proxy
                for batch in range(20):
                    for k in range(100 * batch, 100 * batch + 100):
                        sock.sendto(b"%s%d" % (way.encode(), k), dest)
                    wait_until(lambda: proxy.passed[way] + proxy.dropped[way] >= 100 * batch + 100, 10,
                               f"the proxy handling {way}link batch {batch}")
                    while way == "up" and len(got) < proxy.passed["up"]:
                        got.append(e.upstream.recv(100))
            for way in ("up", "down"):
                assert 0.17 < proxy.dropped[way] / 2000 < 0.23, (way, proxy.dropped)
            # what passed really arrived, in order
            assert got == sorted(got, key=lambda b: int(b[2:])) and len(set(got)) == len(got)
            counts.append(dict(proxy.dropped))
        finally:
            e.close()
    assert counts[0] == counts[1]        # same seed, same packets: the same losses


def _frame(k: int) -> bytes:
    """A MAVLink 2 frame of the tower's (sysid 255): a HEARTBEAT-sized stand-in, seq k."""
    payload = bytes([k % 256]) * 9
    return bytes([0xFD, len(payload), 0, 0, k % 256, 255, 190, 0, 0, 0]) + payload + b"\x00\x00"


def test_lockstep_frames_always_pass_uncounted_and_shift_no_other_frame_s_fate():
    # TOWERLINK_LOCKSTEP is the simulator's clock, not radio traffic: even at 90 % loss every
    # ACK passes, in order, and the fates of the radio frames around them are those without them
    fates = []
    for with_acks in (False, True):
        e = Ends(up=LinkSettings(loss=0.9), seed=4)
        try:
            acks = [L.pack(L.ACK, k * 40000, participant=L.TOWER, sysid=255, compid=190) for k in range(50)]
            sent = []
            for k in range(50):
                if with_acks:
                    e.client.sendto(acks[k], e.front)
                e.client.sendto(_frame(k), e.front)
                sent.append(_frame(k))
            wait_until(lambda: e.proxy.passed["up"] + e.proxy.dropped["up"] == 50, 5, "the proxy handling them")
            got = [e.upstream.recv(200) for _ in range(e.proxy.passed["up"] + (50 if with_acks else 0))]
            assert sum(e.proxy.dropped.values()) > 30
            if with_acks:
                assert [g for g in got if L.is_lockstep(g)] == acks        # all of them, in order
            fates.append([g for g in got if not L.is_lockstep(g)])
        finally:
            e.close()
    assert fates[0] == fates[1]


def _tick(t_usec: int, lag: int = 0) -> bytes:
    return L.pack(L.TICK, t_usec, period_usec=40000, sysid=250, compid=191, lag=lag)


def _ack(t_usec: int) -> bytes:
    return L.pack(L.ACK, t_usec, participant=L.TOWER, sysid=255, compid=190)


def _recv(sock: socket.socket, expected: bytes) -> bytes:
    """Datagrams until as many bytes as `expected` came (the proxy may join frames into one)."""
    got = b""
    while len(got) < len(expected):
        got += sock.recv(2000)
    return got


@pytest.mark.parametrize("lag", [0, 1])
def test_lockstep_delay_is_counted_in_ticks_and_faults_go_up_before_the_tower_s_ack(lag):
    # down latency 0.1 s sim: a frame sent before TICK(0.04) arrives just before TICK(0.16),
    # however slowly the TICKs come; the drone's fault at t = 0.08 goes up just before the
    # tower's ACK(0.08), so the world applies it at that TICK (pipelined, lag 1: at the next)
    fault = Fault(0, 0.08, "drone", 1, params=(("SIM_BATT_VOLTAGE", 10.0),))
    timeline = FaultTimeline([fault], {"up": LinkSettings(), "down": LinkSettings(latency=0.1)},
                             kinds={1: "copter"}, tables={"copter": {"SIM_BATT_VOLTAGE": _Def()}})
    e = Ends(lockstep=True, timeline=timeline, encode=lambda p: _frame(200 + int(p.value)))
    try:
        e.client.sendto(_ack(0), e.front)              # the client's address, before any TICK
        assert _recv(e.upstream, _ack(0)) == _ack(0)
        e.upstream.sendto(_tick(0, lag), e.back)
        assert _recv(e.client, _tick(0, lag)) == _tick(0, lag)
        e.upstream.sendto(_frame(1), e.back)           # telemetry of the frame up to 0.04
        for t in (40000, 80000, 120000, 160000):
            e.upstream.sendto(_tick(t, lag), e.back)
            down = (_frame(1) if t == 160000 else b"") + _tick(t, lag)
            assert _recv(e.client, down) == down, t
            e.client.sendto(_ack(t), e.front)
            up = (_frame(210) if t == 80000 else b"") + _ack(t)
            assert _recv(e.upstream, up) == up, t
        assert e.proxy.applied == [{"fault": 0, "kind": "apply", "t": 0.08, "at": 0.08 + 0.04 * lag}]
        assert e.proxy.injected == 1
    finally:
        e.close()


class _Def:
    """A parameter definition's stand-in for the timeline's checks."""
    lo, hi, integer, default, mav_type = 0.0, 100.0, False, 12.6, 9


def test_the_bridge_s_wall_paced_frames_are_told_apart():
    from common.mavlink.dialect import encoder
    from common.mavlink.dialect import towerlink as tl
    mav = encoder(250, 191)

    def unit(msg) -> Unit:
        data = msg.pack(mav)
        return Unit(data, (250, 191, msg.id))

    tf = dict(time_usec=5, frame_id=b"world", child_frame_id=b"drone", translation=[1, 2, 3], rotation=[0, 0, 0, 1])
    assert bridge_wall_paced(unit(tl.MAVLink_towerlink_transform_message(**tf, flags=1)))
    assert not bridge_wall_paced(unit(tl.MAVLink_towerlink_transform_message(**tf, flags=0)))
    assert bridge_wall_paced(unit(tl.MAVLink_towerlink_bridge_status_message(1, b"tower", 1, 2, 3, 4, 5, 6, 0, 0)))
    assert not bridge_wall_paced(unit(tl.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3)))


def test_param_set_is_what_the_fault_says():
    from common.mavlink.dialect import towerlink as tl
    from tools.fault_params import FAULTS_COMPONENT, ParamSetEncoder
    data = ParamSetEncoder()(ParamSet(2, "SIM_BATT_VOLTAGE", 10.5, 9))
    m = tl.MAVLink(None).decode(bytearray(data))
    assert (m.get_type(), m.target_system, m.target_component, m.param_value, m.param_type) == \
        ("PARAM_SET", 2, 1, 10.5, 9)
    assert m.param_id == "SIM_BATT_VOLTAGE" and (m.get_srcSystem(), m.get_srcComponent()) == (255, FAULTS_COMPONENT)
    key = bytes(range(32))
    signed = ParamSetEncoder(key)(ParamSet(2, "SIM_BATT_VOLTAGE", 10.5, 9))
    from common.mavlink.signing import SignatureCheck
    assert SignatureCheck(key).check(signed, 255, FAULTS_COMPONENT) is None
