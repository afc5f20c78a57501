"""The vehicle's fast packer (vehicle/link/framing.py) against pymavlink's own packing.

Every telemetry message type, from drones and rovers, with and without signing: the frame the
link streams is byte for byte the frame pymavlink packs from the message object with the same
link state (sequence number, ids, signing timestamp), and pymavlink decodes it (CRC, signature)
to the same field values. Hypothesis drives the field values (zeros included, so MAVLink 2's
trailing-zero trimming is exercised), the CRC's input and the link state.
"""
from __future__ import annotations

import copy
import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.link import framing
from vehicle.link.framing import Framer, layout, x25crc
from vehicle.world import World, WorldConfig

KEY = bytes(range(32))
# every message the vehicle can stream or send on request (Telemetry.builders)
TELEMETRY_IDS = (0, 1, 24, 33, 32, 30, 31, 74, 242, 245, 2, 147, 85, 108, 148, 42, 49,
                 27, 116, 29, 241, 193, 163, 178, 36, 65, 34, 62, 87, 125, 152, 162,
                 129, 137, 143, 164, 168, 194, 83, 11030)


# what a flying vehicle has nothing to say about (SITL has no third barometer either)
NOTHING_TO_SAY = {("copter", mav.MAVLINK_MSG_ID_RC_CHANNELS_SCALED), ("rover", mav.MAVLINK_MSG_ID_WIND),
                  ("rover", mav.MAVLINK_MSG_ID_ATTITUDE_TARGET), ("rover", mav.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4)}


class _Out:
    def write(self, b):
        pass


def _link_mav(sysid: int = 1, seq: int = 0, key: bytes | None = None, timestamp: int = 0):
    m = mav.MAVLink(_Out(), srcSystem=sysid, srcComponent=1)
    m.seq = seq
    if key:
        m.signing.secret_key = key
        m.signing.sign_outgoing = True
        m.signing.link_id = 0
        m.signing.timestamp = timestamp
    return m


def _decode(buf: bytes, key: bytes | None):
    """pymavlink's parse of one frame (signature checked when a key is given)."""
    rx = mav.MAVLink(_Out(), srcSystem=255, srcComponent=0)
    if key:
        rx.signing.secret_key = key
        rx.signing.allow_unsigned_callback = lambda *_: False
    msgs = rx.parse_buffer(buf)
    assert msgs is not None and len(msgs) == 1, msgs
    return msgs[0]


def _wire_eq(got, want) -> bool:
    """Equal as the wire holds them: floats as float32 (NaN equal to NaN), lists elementwise."""
    if isinstance(want, (list, tuple)):
        return len(got) == len(want) and all(_wire_eq(a, b) for a, b in zip(got, want))
    if isinstance(want, float):
        want = struct.unpack("<f", struct.pack("<f", want))[0] if isinstance(got, float) else want
        return (math.isnan(got) and math.isnan(want)) or got == want
    return got == want


def _same_fields(got, want) -> None:
    assert got.get_type() == want.get_type()
    for name in want.fieldnames:
        assert _wire_eq(getattr(got, name), getattr(want, name)), (name, getattr(got, name), getattr(want, name))


def test_the_layouts_cover_every_telemetry_message():
    from vehicle.link.telemetry import Telemetry
    assert set(TELEMETRY_IDS) == set(Telemetry(None, None, None).builders)
    for msgid in TELEMETRY_IDS:
        assert layout(msgid).cls is mav.mavlink_map[msgid]


@given(st.binary(max_size=300))
def test_x25crc_is_pymavlinks(data):
    assert x25crc(data) == mav.x25crc(data).crc


# ---------------------------------------------------------------- field values by hypothesis
_INTS = {"int8_t": (-128, 127), "uint8_t": (0, 255), "int16_t": (-2**15, 2**15 - 1), "uint16_t": (0, 2**16 - 1),
         "int32_t": (-2**31, 2**31 - 1), "uint32_t": (0, 2**32 - 1), "int64_t": (-2**63, 2**63 - 1),
         "uint64_t": (0, 2**64 - 1), "uint8_t_mavlink_version": (0, 255)}


def _scalar(t: str):
    if t in ("float", "double"):
        return st.one_of(st.just(0.0), st.floats(allow_nan=True, allow_infinity=True,
                                                 width=32 if t == "float" else 64))
    lo, hi = _INTS[t]
    return st.one_of(st.just(0), st.integers(lo, hi))


def _values(cls):
    """Constructor-order values of `cls`, zeros weighted in (so payloads end in zeros)."""
    types = dict(zip(cls.fieldnames, cls.fieldtypes))
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths))
    parts = []
    for name in cls.fieldnames:
        t, n = types[name], lengths[name]
        parts.append(st.lists(_scalar(t), min_size=n, max_size=n) if n else _scalar(t))
    return st.tuples(*parts)


@pytest.mark.parametrize("msgid", TELEMETRY_IDS)
@settings(max_examples=30, deadline=None)
@given(data=st.data(), signed=st.booleans(), seq=st.integers(0, 255), sysid=st.integers(1, 255),
       stamp=st.integers(0, 2**48 - 2))
def test_frames_equal_pymavlinks_for_any_field_values(msgid, data, signed, seq, sysid, stamp):
    cls = mav.mavlink_map[msgid]
    values = data.draw(_values(cls))
    key = KEY if signed else None
    ours = _link_mav(sysid, seq, key, stamp)
    theirs = _link_mav(sysid, seq, key, stamp)
    buf = Framer(ours).frame(msgid, values)
    want = cls(*values)
    assert buf == want.pack(theirs)
    assert ours.signing.timestamp == theirs.signing.timestamp      # one signature each
    _same_fields(_decode(buf, key), want)


def test_an_all_zero_payload_keeps_one_byte():
    buf = Framer(_link_mav()).frame(mav.MAVLINK_MSG_ID_SYSTEM_TIME, (0, 0))
    assert buf[1] == 1 and buf[10] == 0            # payload length 1: MAVLink 2 keeps one byte
    assert buf == mav.MAVLink_system_time_message(0, 0).pack(_link_mav())


def test_message_objects_frame_the_same_char_fields_included():
    msg = mav.MAVLink_statustext_message(mav.MAV_SEVERITY_INFO, b"Arming motors", 0, 0)
    assert Framer(_link_mav(5, 17, KEY, 99)).frame_message(msg) == msg.pack(_link_mav(5, 17, KEY, 99))


def test_a_shorter_tuple_takes_the_constructors_defaults():
    values = (1234, 1.0, 0.0, 0.0, 0.0, 0.1, 0.2, 0.3)            # no repr_offset_q
    want = mav.MAVLink_attitude_quaternion_message(*values)
    assert Framer(_link_mav()).frame(mav.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, values) == want.pack(_link_mav())


# ---------------------------------------------------------------- the world's vehicles
@pytest.fixture(scope="module", params=[None, KEY], ids=["unsigned", "signed"])
def flying_world(request):
    """Vector fleets (more than fleet.SCALAR_MAX of each kind), armed and moving, with home,
    EKF origin and targets set, so every message has something to say."""
    w = World(WorldConfig(drones=9, rovers=9, state_dir=None, tcp_base=None, udp_base=None,
                          outs=["udpout:127.0.0.1:9"], signing_key=request.param, start_at=1.7e9))
    w.run_for(2.0)
    for k, v in enumerate(w.vehicles):
        if v.kind == "copter":
            v.ap.set_mode(4)
            assert v.ap.arm() == mav.MAV_RESULT_ACCEPTED
            v.ap.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 5.0])
        else:
            v.ap.set_mode(15)
            assert v.ap.arm() == mav.MAV_RESULT_ACCEPTED
            v.ap.position_target_local(mav.MAV_FRAME_LOCAL_NED, 0b110111111000, (10.0 + k, 5.0, 0.0),
                                       (0, 0, 0), (0, 0, 0), 0, 0)
    for v in w.vehicles:                    # FENCE_STATUS is sent while the fence is on
        assert v.ap.params.set("FENCE_ENABLE", 1, save=False) is None
        assert v.ap.params.set("FENCE_ACTION", 0, save=False) is None
        assert v.ap.params.set("GCS_PID_MASK", 15, save=False) is None      # PID_TUNING on
    w.run_for(1.0)
    yield w, request.param
    for v in w.vehicles:
        v.link.close()


@pytest.mark.parametrize("kind", ["copter", "rover"])
def test_every_telemetry_frame_is_pymavlinks_frame_of_the_message(flying_world, kind):
    w, key = flying_world
    v = next(v for v in w.vehicles if v.kind == kind)
    link = v.link
    for msgid in TELEMETRY_IDS:
        wants = link.telemetry.build_all(msgid)      # PID_TUNING: one per enabled axis
        want = wants[0] if wants else None
        if want is None:       # a copter has no rover outputs to scale, a rover no wind vane
            assert (kind, msgid) in NOTHING_TO_SAY or msgid == mav.MAVLINK_MSG_ID_SCALED_PRESSURE3 or (
                msgid == mav.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4 and w.t < 6.0), (kind, msgid)   # SITL: none at first
            continue
        assert want is not None, msgid                 # flying: every message has a value
        theirs = copy.copy(link.mav)
        theirs.signing = copy.copy(link.mav.signing)
        buf = link.telemetry.frame(msgid)
        packed = []
        for w_ in wants:                             # consecutive sequence numbers
            packed.append(w_.pack(theirs))
            theirs.seq = (theirs.seq + 1) % 256
        assert buf == b"".join(packed), want.get_type()
        assert len(wants) == (4 if msgid == mav.MAVLINK_MSG_ID_PID_TUNING and kind == "copter"
                              else 2 if msgid == mav.MAVLINK_MSG_ID_PID_TUNING else 1)
        buf = packed[0]
        _same_fields(_decode(buf, key), want)
        assert (buf[2] & framing.IFLAG_SIGNED) == (1 if key else 0)


def test_the_streams_decode_with_every_sequence_number_once(flying_world):
    w, key = flying_world
    v = w.vehicles[-1]
    sent: list[bytes] = []
    saved = [ep.send for ep in v.link.endpoints]
    for ep in v.link.endpoints:
        ep.send = sent.append
    try:
        w.run_for(1.0)
    finally:
        for ep, s in zip(v.link.endpoints, saved):
            ep.send = s
    rx = mav.MAVLink(_Out(), srcSystem=255, srcComponent=0)
    if key:
        rx.signing.secret_key = key
        rx.signing.allow_unsigned_callback = lambda *_: False
    msgs = rx.parse_buffer(b"".join(sent)) or []
    assert msgs and not [m for m in msgs if m.get_type() == "BAD_DATA"]
    assert {m.get_type() for m in msgs} >= {"HEARTBEAT", "SYS_STATUS", "GLOBAL_POSITION_INT", "ATTITUDE",
                                           "ATTITUDE_QUATERNION", "SIM_STATE", "VFR_HUD", "SYSTEM_TIME"}
    seqs = [m.get_seq() for m in msgs]
    assert all((b - a) % 256 == 1 for a, b in zip(seqs, seqs[1:]))
    assert all(m.get_srcSystem() == v.sysid for m in msgs)
    assert all(m.get_signed() == bool(key) for m in msgs)
