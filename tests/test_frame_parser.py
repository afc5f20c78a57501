"""The one MAVLink 1/2 frame parser (common.mavlink.frame_parser) and its CRC
(common.mavlink.crc), against pymavlink's own packing and checksum."""
from __future__ import annotations

import random

import pytest
from pymavlink.generator.mavcrc import x25crc_slow

from common.mavlink.crc import x25crc, x25crc_portable
from common.mavlink.dialect import towerlink as tl
from common.mavlink.frame_parser import FrameParser, message_table

TABLE = message_table(tl.mavlink_map)
KEY = bytes(range(32))


def _crc_reference(data: bytes) -> int:
    return x25crc_slow(data).crc


@pytest.mark.parametrize("seed", range(5))
def test_crc_matches_pymavlink_and_continues(seed):
    rng = random.Random(seed)
    data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300)))
    cut = rng.randrange(len(data) + 1)
    assert x25crc(data) == x25crc_portable(data) == _crc_reference(data)
    assert x25crc(data[cut:], x25crc(data[:cut])) == x25crc(data)
    assert x25crc_portable(data[cut:], x25crc_portable(data[:cut])) == x25crc(data)


def _frames(rng: random.Random) -> list[tuple[bytes, object, bool]]:
    """(frame, message, v2) for messages of every kind the parser meets: v1, v2, signed v2,
    with and without a target, with zero-truncated payloads."""
    out = []
    msgs = [tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3),
            tl.MAVLink_command_long_message(7, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0),
            tl.MAVLink_set_position_target_local_ned_message(5, 2, 9, 1, 0, 1.0, 2.0, 3.0, 0, 0, 0, 0, 0, 0, 0, 0),
            tl.MAVLink_param_request_read_message(3, 0, b"WPNAV_SPEED", -1),
            tl.MAVLink_towerlink_lockstep_message(40000, 0, 3, 0, 40000),
            tl.MAVLink_command_long_message(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)]   # all zeros: 1 payload byte
    for k, msg in enumerate(msgs * 3):
        mav = tl.MAVLink(None, rng.randrange(256), rng.randrange(256))
        mav.seq = rng.randrange(256)
        signed = k % 3 == 2
        if signed:
            mav.signing.secret_key, mav.signing.sign_outgoing, mav.signing.timestamp = KEY, True, 7
        v1 = k % 3 == 1 and msg.id < 256
        out.append((bytes(msg.pack(mav, force_mavlink1=v1)), msg, not v1))
    return out


def test_every_frame_is_cut_with_its_header_and_targets():
    rng = random.Random(1)
    for frame, msg, v2 in _frames(rng):
        p = FrameParser(TABLE)
        (pkt,) = p.feed(frame, datagram=True)
        decoded = tl.MAVLink(None).decode(bytearray(frame))
        hdr = decoded.get_header()
        assert pkt.raw == frame and pkt.v2 == v2 and pkt.msgid == msg.id
        assert (pkt.sysid, pkt.compid, pkt.seq) == (hdr.srcSystem, hdr.srcComponent, hdr.seq)
        assert pkt.target_system == getattr(msg, "target_system", 0)
        assert pkt.target_component == getattr(msg, "target_component", 0)
        assert p.malformed == 0 and p.packets == 1


def test_a_stream_cut_anywhere_gives_the_same_packets():
    rng = random.Random(2)
    frames = [f for f, _m, _v in _frames(rng)]
    stream = b"".join(frames)
    for cut in range(0, len(stream), 7):
        p = FrameParser(TABLE)
        got = p.feed(stream[:cut]) + p.feed(stream[cut:])
        assert [x.raw for x in got] == frames and p.malformed == 0 and not p.buf


def test_what_is_not_a_frame_is_counted_once_per_run_and_skipped():
    ok = bytes(tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(tl.MAVLink(None, 1, 1)))
    ok1 = bytes(tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(tl.MAVLink(None, 1, 1), force_mavlink1=True))
    bad_crc = ok[:-1] + bytes((ok[-1] ^ 0xFF,))
    bad_crc1 = ok1[:-1] + bytes((ok1[-1] ^ 0xFF,))
    unknown_flag = ok[:2] + bytes((0x02,)) + ok[3:]
    unknown_id = ok[:7] + b"\x39\x30\x00" + ok[10:]             # msgid 12345
    cases = [(b"garbage" + ok, 1, 1), (bad_crc + ok, 1, 1), (bad_crc1 + ok1, 1, 1),
             (unknown_flag + ok, 1, 1), (unknown_id + ok1, 1, 1),
             (b"xx" + ok + b"yy" + ok1 + b"zz", 3, 2)]
    for data, malformed, packets in cases:
        p = FrameParser(TABLE)
        got = p.feed(data, datagram=True)
        assert (p.malformed, len(got)) == (malformed, packets), data
    p = FrameParser(TABLE)
    assert p.feed(ok + ok1[:-3], datagram=True)[0].raw == ok and p.malformed == 1 and not p.buf
    p = FrameParser(TABLE)
    assert p.feed(ok1[:-3]) == [] and p.malformed == 0 and bytes(p.buf) == ok1[:-3]   # a stream waits


# ------------------------------------------------------ a whole datagram cut straight from its bytes

from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

_TABLE = message_table(tl.mavlink_map)


def _valid_frames():
    enc = tl.MAVLink(None, srcSystem=7, srcComponent=1)
    hb = tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3)
    return [hb.pack(enc), hb.pack(enc, force_mavlink1=True),
            tl.MAVLink_local_position_ned_message(1234, 1.0, -2.0, 3.5, 0.0, 0.0, 0.0).pack(enc)]


_PIECES = st.lists(st.one_of(st.sampled_from(_valid_frames()), st.binary(max_size=20),
                             st.sampled_from([b"\xfd", b"\xfe", b"\xfd\x09\x00\x00"])), max_size=6)


def _seen(parser: FrameParser, datagrams, kind) -> tuple:
    pkts = [[(p.raw, p.msgid, p.sysid, p.compid, p.seq, p.target_system, p.target_component, p.v2)
             for p in parser.feed(kind(d), datagram=True)] for d in datagrams]
    return pkts, parser.malformed, parser.packets, parser._skipping, bytes(parser.buf)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_PIECES.map(b"".join), min_size=1, max_size=4), st.binary(max_size=8))
def test_a_datagram_of_bytes_is_cut_as_the_same_datagram_copied(datagrams, stream_tail):
    # the direct path (bytes, nothing pending) and the copying one (a bytearray) agree on every
    # datagram, also after a stream's partial frame was left pending
    for lead in (b"", stream_tail):
        a, b = FrameParser(_TABLE), FrameParser(_TABLE)
        a.feed(lead), b.feed(bytearray(lead))
        assert _seen(a, datagrams, bytes) == _seen(b, datagrams, bytearray)
