"""common.mavlink.message_codec against pymavlink, for every message of the towerlink dialect:
the same bytes packed (MAVLink 2 with zero-trimmed payloads, and MAVLink 1), and the same
message decoded (fields, header, CRC, buffer), signed frames included; what pymavlink refuses
(bad CRC, bad length) is refused."""
from __future__ import annotations

import random
import struct

import pytest

from common.mavlink.dialect import encoder, towerlink as tl
from common.mavlink.message_codec import MessageCodec
from common.mavlink.signing import setup_signing

CODEC = MessageCodec(tl)
_INT = {"int8_t": (-128, 127), "uint8_t": (0, 255), "int16_t": (-2**15, 2**15 - 1), "uint16_t": (0, 2**16 - 1),
        "int32_t": (-2**31, 2**31 - 1), "uint32_t": (0, 2**32 - 1), "int64_t": (-2**63, 2**63 - 1),
        "uint64_t": (0, 2**64 - 1), "uint8_t_mavlink_version": (0, 255)}


def _value(rng: random.Random, ftype: str, zero: bool):
    if zero:
        return 0.0 if ftype in ("float", "double") else 0
    if ftype == "float":
        return struct.unpack("<f", struct.pack("<f", rng.uniform(-1e4, 1e4)))[0]
    if ftype == "double":
        return rng.uniform(-1e9, 1e9)
    lo, hi = _INT[ftype]
    return rng.randint(lo, hi)


def _message(cls, rng: random.Random):
    """An instance with random fields; a random tail of them zero (MAVLink 2 trims it)."""
    alen = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
    zero_from = rng.randrange(len(cls.ordered_fieldnames) + 1)
    zero = {f for f in cls.ordered_fieldnames[zero_from:]}
    args = []
    for f, ftype in zip(cls.fieldnames, cls.fieldtypes):
        n = alen[f]
        if ftype == "char":
            k = 0 if f in zero else rng.randrange(max(n, 1) + 1)
            args.append(bytes(rng.randrange(33, 127) for _ in range(min(k, max(n, 1)))))
        elif n:
            args.append([_value(rng, ftype, f in zero) for _ in range(n)])
        else:
            args.append(_value(rng, ftype, f in zero))
    return cls(*args)


def _same(a, b) -> None:
    assert type(a) is type(b)
    da, db = dict(vars(a)), dict(vars(b))
    ha, hb = da.pop("_header"), db.pop("_header")
    assert vars(ha) == vars(hb)
    assert da == db


@pytest.mark.parametrize("seed", range(3))
def test_every_message_packs_and_decodes_as_pymavlink_does(seed):
    rng = random.Random(seed)
    for msgid, cls in sorted(tl.mavlink_map.items()):
        msg = _message(cls, rng)
        seq, sysid, compid = rng.randrange(256), rng.randrange(256), rng.randrange(256)
        enc = encoder(sysid, compid)
        enc.seq = seq
        want = msg.pack(enc)
        assert CODEC.pack(msg, seq, sysid, compid) == want, cls.msgname
        _same(CODEC.decode(want), tl.MAVLink(None).decode(bytearray(want)))
        if msgid < 256:
            want1 = msg.pack(enc, force_mavlink1=True)
            assert CODEC.pack(msg, seq, sysid, compid, v2=False) == want1, cls.msgname
            _same(CODEC.decode(want1), tl.MAVLink(None).decode(bytearray(want1)))


def test_signed_frames_decode_as_pymavlink_does():
    enc = encoder(3, 1)
    setup_signing(enc, bytes(range(32)), link_id=2)
    raw = tl.MAVLink_local_position_ned_message(1234, 1.0, -2.0, 3.5, 0.0, 0.0, 0.0).pack(enc)
    assert raw[2] & 1
    _same(CODEC.decode(raw), tl.MAVLink(None).decode(bytearray(raw)))


def test_what_pymavlink_refuses_is_refused_and_the_rest_read_as_it_does():
    raw = bytearray(tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(encoder(1, 1)))
    bad_crc = bytes(raw[:-1]) + bytes(((raw[-1] + 1) & 0xFF,))
    for bad in (bad_crc, bytes(raw[:-3]) + bytes(raw[-2:]), b"\x00" * 12):
        with pytest.raises(Exception) as theirs:
            tl.MAVLink(None).decode(bytearray(bad))
        with pytest.raises(type(theirs.value)):
            CODEC.decode(bad)
    unknown = bytearray(tl.MAVLink_heartbeat_message(2, 3, 0, 0, 4, 3).pack(encoder(1, 1), force_mavlink1=True))
    unknown[5] = min(set(range(256)) - set(tl.mavlink_map))    # a message id the dialect does not have
    got, want = CODEC.decode(bytes(unknown)), tl.MAVLink(None).decode(bytearray(unknown))
    assert type(got) is type(want) and got.get_type() == want.get_type()
