"""UDP peers of a vehicle (issue 8 items 2 and 7), on real sockets: a sender becomes a peer only
after a packet that passed the checks (and the signature, with signing on); a silent peer is
dropped after PEER_TIMEOUT wall seconds (30); at most MAX_PEERS (64), the most recent kept."""
from __future__ import annotations

import hashlib
import socket
import subprocess
import sys

import pytest

from support import free_port, wait_until
from test_sitl_support import mav
from pymavlink.dialects.v20 import ardupilotmega as v20
from vehicle.link import endpoints
from vehicle.link.endpoints import UdpIn
from vehicle.world import World, WorldConfig

pytestmark = pytest.mark.timeout(60)
KEY = hashlib.sha256(b"peers test").digest()


class _Out:
    def write(self, b):
        pass


def _encoder(signed=False, sysid=255):
    m = v20.MAVLink(_Out(), srcSystem=sysid, srcComponent=190)
    if signed:
        m.signing.secret_key = KEY
        m.signing.sign_outgoing = True
        m.signing.link_id = 1
        import time
        m.signing.timestamp = int((time.time() - 1420070400) * 1e5)
    return m


def _heartbeat(enc) -> bytes:
    return enc.heartbeat_encode(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0).pack(enc)


def _sock():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.setblocking(False)
    return s


def _drain(s) -> int:
    n = 0
    while True:
        try:
            s.recv(65536)
            n += 1
        except BlockingIOError:
            return n


def _got(s) -> bool:
    return _drain(s) > 0


@pytest.fixture
def world(request):
    signing = getattr(request, "param", None)
    port = free_port()
    w = World(WorldConfig(drones=1, rovers=0, state_dir=None, tcp_base=None, udp_base=None,
                          endpoints={0: [f"udpin:127.0.0.1:{port}"]}, signing_key=signing))
    w.start_thread()
    try:
        yield w, ("127.0.0.1", port), w.vehicles[0].link.endpoints[0]
    finally:
        w.stop()


def test_garbage_and_bad_crc_senders_are_no_peers(world):
    w, dst, ep = world
    bad, good = _sock(), _sock()
    hb = _heartbeat(_encoder())
    bad_crc = bytearray(hb)
    bad_crc[-1] ^= 0xFF
    bad.sendto(b"\xfd\x09garbage" * 20, dst)
    bad.sendto(bytes(bad_crc), dst)
    bad.sendto(hb[:8], dst)                           # truncated
    good.sendto(hb, dst)
    wait_until(lambda: _got(good), 5, "telemetry to the valid sender")
    # the vehicle sends each batch to every peer in one pass: had `bad` been one, it has it now
    wait_until(lambda: _got(good), 5, "a second batch to the valid sender")
    assert not _got(bad)
    assert bad.getsockname() not in ep.peers and good.getsockname() in ep.peers


@pytest.mark.parametrize("world", [KEY], indirect=True, ids=["signing"])
def test_with_signing_only_signed_senders_are_peers(world):
    w, dst, ep = world
    unsigned, wrong, signed = _sock(), _sock(), _sock()
    unsigned.sendto(_heartbeat(_encoder()), dst)
    enc = _encoder(signed=True)
    enc.signing.secret_key = hashlib.sha256(b"wrong").digest()
    wrong.sendto(_heartbeat(enc), dst)
    signed.sendto(_heartbeat(_encoder(signed=True)), dst)
    wait_until(lambda: _got(signed), 5, "telemetry to the signed sender")
    wait_until(lambda: _got(signed), 5, "a second batch to the signed sender")
    assert not _got(unsigned) and not _got(wrong)
    assert set(ep.peers) == {signed.getsockname()}
    stats = w.vehicles[0].link.stats
    assert stats["unsigned"] >= 1 and stats["bad_signature"] >= 1


def test_silent_peer_dropped_after_timeout(world):
    w, dst, ep = world
    ep.peer_timeout = 0.5                       # the default, 30 s, is checked below on a fake clock
    quiet, talker = _sock(), _sock()
    enc = _encoder()
    quiet.sendto(_heartbeat(enc), dst)
    wait_until(lambda: _got(quiet), 5, "telemetry to the quiet peer")
    for _ in range(200):                        # the talker keeps talking; the quiet one stops
        talker.sendto(_heartbeat(enc), dst)
        if quiet.getsockname() not in ep.peers:
            break
        wait_until(lambda: _got(talker), 5, "telemetry to the talker")
    assert quiet.getsockname() not in ep.peers and talker.getsockname() in ep.peers
    _drain(quiet)
    talker.sendto(_heartbeat(enc), dst)
    wait_until(lambda: _got(talker), 5, "telemetry to the talker")
    wait_until(lambda: _got(talker), 5, "another batch to the talker")
    assert not _got(quiet)
    # a dropped peer that speaks again is a peer again
    quiet.sendto(_heartbeat(enc), dst)
    wait_until(lambda: _got(quiet), 5, "telemetry to the returning peer")


def test_default_timeout_is_30_wall_seconds():
    now = [100.0]
    ep = UdpIn("127.0.0.1", 0, lambda data, ch: True, clock=lambda: now[0])
    assert ep.peer_timeout == endpoints.PEER_TIMEOUT == 30.0 and ep.max_peers == 64
    ep.received(b"x", ("10.0.0.1", 1))
    now[0] += 29.0
    ep.received(b"x", ("10.0.0.2", 2))

    def expire_at(t):
        now[0] = t
        ep.next_expiry = 0.0            # expire() runs at most once a second; force it here
        ep.expire()
        return list(ep.peers)

    assert expire_at(129.9) == [("10.0.0.1", 1), ("10.0.0.2", 2)]    # 29.9 s silent: kept
    assert expire_at(130.5) == [("10.0.0.2", 2)]                      # 30.5 s silent: dropped
    assert expire_at(158.9) == [("10.0.0.2", 2)]
    assert expire_at(159.5) == []
    rejected = UdpIn("127.0.0.1", 0, lambda data, ch: False)
    rejected.received(b"garbage", ("10.0.0.3", 3))
    assert not rejected.peers


def test_at_most_64_peers_most_recent_kept(world):
    w, dst, ep = world
    socks = [_sock() for _ in range(70)]
    hb = _heartbeat(_encoder())
    for s in socks:
        s.sendto(hb, dst)
    last = socks[-1]
    wait_until(lambda: _got(last), 5, "telemetry to the last peer")
    assert len(ep.peers) == 64
    assert set(ep.peers) == {s.getsockname() for s in socks[6:]}
    for s in socks[:6]:
        _drain(s)
    wait_until(lambda: _got(last), 5, "another batch to the last peer")
    assert not any(_got(s) for s in socks[:6])


def test_sitl_help_states_the_peer_rules():
    out = subprocess.run([sys.executable, "-m", "tools.cli", "sitl", "--help"], capture_output=True,
                         text=True, timeout=30).stdout
    assert "silent for 30 s" in out and "64 peers" in out


def test_no_streams_are_built_until_a_peer_is_heard(world):
    """Nobody to hear (a udpin without peers): the link builds no telemetry, so a big world of
    idle endpoints costs little; the first valid packet starts the streams."""
    w, dst, ep = world
    link = w.vehicles[0].link
    built: list[int] = []
    frame = link.telemetry.frame
    link.telemetry.frame = lambda msgid: built.append(msgid) or frame(msgid)
    t0 = w.t
    wait_until(lambda: w.t > t0 + 1.5, 10, "a sim second and a half")
    assert built == [] and len(ep.peers) == 0
    gcs = _sock()
    gcs.sendto(_heartbeat(_encoder()), dst)
    wait_until(lambda: _got(gcs), 5, "telemetry once a peer is heard")
    assert mav.MAVLINK_MSG_ID_ATTITUDE in built
    wait_until(lambda: mav.MAVLINK_MSG_ID_HEARTBEAT in built, 5, "the 1 Hz HEARTBEAT too")
