"""tools.tlog_stamped's StampedDecoder against pymavlink on hand-built tlog frames: a frame it
reads only for its time is kept exactly when pymavlink decodes it (right checksum, signed or
not, MAVLink 1 or 2, payload trimmed or longer than the message), with the same time fields,
sender, tlog stamp and link bits."""
from __future__ import annotations

import struct

from hypothesis import HealthCheck, given, settings, strategies as st

from common.mavlink.crc import x25crc
from common.mavlink.dialect import towerlink as tl
from tools.run_data import tlog_frames
from tools.tlog_stamped import StampedDecoder, decode_frames

DECODER = StampedDecoder(("TOWERLINK_TRANSFORM",))
_TIMED = sorted(DECODER.timed)


@st.composite
def _frame(draw):
    v1 = draw(st.booleans())
    msgid = draw(st.sampled_from([i for i in _TIMED if i < 256] if v1 else _TIMED))
    payload = draw(st.binary(max_size=255))
    ids = (draw(st.integers(0, 255)), draw(st.integers(0, 255)), draw(st.integers(0, 255)))
    if v1:
        body = bytes((0xFE, len(payload), *ids, msgid)) + payload
    else:
        incompat = draw(st.sampled_from([0, 1, 2, 3]))
        body = struct.pack("<BBBBBBBHB", 0xFD, len(payload), incompat, 0, *ids, msgid & 0xFFFF, msgid >> 16) + payload
    good = x25crc(body[1:] + bytes((tl.mavlink_map[msgid].crc_extra,)))
    crc = good if draw(st.booleans()) else draw(st.integers(0, 0xFFFF))
    raw = body + struct.pack("<H", crc)
    if not v1 and body[2] & 1:
        raw += draw(st.binary(min_size=13, max_size=13))
    return struct.pack(">Q", draw(st.integers(0, 2**63))) + raw


def _theirs(m):
    return (m.get_type(), m.get_srcSystem(), getattr(m, "time_usec", None), getattr(m, "time_boot_ms", None),
            m._timestamp, m._link)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(_frame(), min_size=1, max_size=8))
def test_a_frame_read_for_its_time_is_kept_exactly_when_pymavlink_decodes_it(parts):
    raw = b"".join(parts)
    frames = tlog_frames(raw)
    assert frames is not None and len(frames) == len(parts)
    want = [_theirs(m) for m in decode_frames(tl.MAVLink(None), raw, frames, None, None)]
    got = [_theirs(m) for m in DECODER.decode(raw, frames)]
    assert got == want
