"""The DataFlash encoder (vehicle/logs/dataflash.py, messages.py) read back by pymavlink's
DFReader, the reader Mission Planner's and MAVExplorer's users rely on: every message
towerlink writes round-trips with ArduPilot's names, formats, units and multipliers."""
from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink import DFReader

from vehicle.logs import messages
from vehicle.logs.dataflash import FMT_TYPE, MessageDef, Schema

SCHEMA = messages.schema("copter")


def read_back(tmp_path, data: bytes, name="t.BIN"):
    path = tmp_path / name
    path.write_bytes(data)
    return DFReader.DFReader_binary(str(path), zero_time_base=True)


def all_messages(reader, kind=None):
    """Every message of type `kind` (all when None) from where the reader is."""
    out = []
    while True:
        m = reader.recv_match()
        if m is None:
            return out
        if kind is None or m.get_type() == kind:
            out.append(m)


def test_header_declares_every_message_with_ardupilot_strings(tmp_path):
    r = read_back(tmp_path, SCHEMA.header(1000))
    for d in messages.COPTER:
        f = r.name_to_id[d.name]
        fmt = r.formats[f]
        assert (fmt.format, ",".join(fmt.columns)) == (d.fmt, d.labels)
    assert r.formats[FMT_TYPE].name == "FMT"
    # UNIT / MULT tables as log_Units / log_Multipliers
    assert r.unit_lookup["d"] == "deg" and r.unit_lookup["Y"] == "us" and r.unit_lookup["#"] == "instance"
    assert r.mult_lookup["G"] == pytest.approx(1e-7) and r.mult_lookup["!"] == pytest.approx(3.6)


def test_units_and_multipliers_attach_to_fields(tmp_path):
    rec = SCHEMA["GPS"].pack(5_000_000, 0, 3, 123456, 2300, 12, 1.21, -35.3632611, 149.1652301, 584.25,
                             3.5, 270.0, -0.25, 0.0, 1)
    r = read_back(tmp_path, SCHEMA.header(0) + rec)
    m = all_messages(r, "GPS")[0]
    fmt = m.fmt
    units = dict(zip(fmt.columns, fmt.units))
    assert units["Lat"] == "deglatitude" and units["Alt"] == "m" and units["Spd"] == "m/s"
    assert units["NSats"] == "satellites" and units["GCrs"] == "degheading"
    assert m.Lat == pytest.approx(-35.3632611, abs=1e-7) and m.Alt == pytest.approx(584.25)
    assert m.HDop == pytest.approx(1.21) and m.GWk == 2300 and m.GMS == 123456


def test_att_centidegrees_and_clamping(tmp_path):
    att = SCHEMA["ATT"]
    recs = (att.pack(1, 1.5, -12.34, 0.0, 7.01, 359.99, 90.5, 0, 0, 3)
            + att.pack(2, 1e9, float("nan"), -1e9, float("inf"), -5, 1e9, 0, 0, 3))
    r = read_back(tmp_path, SCHEMA.header(0) + recs)
    a, b = all_messages(r, "ATT")
    assert (a.DesRoll, a.Roll, a.Pitch, a.DesYaw, a.Yaw, a.AEKF) == pytest.approx((1.5, -12.34, 7.01, 359.99, 90.5, 3))
    # out of range is clamped to the field's type, NaN / inf stored as 0
    assert b.DesRoll == pytest.approx(327.67) and b.Roll == 0 and b.DesPitch == pytest.approx(-327.68)
    assert b.Pitch == 0 and b.DesYaw == 0 and b.Yaw == pytest.approx(655.35)


def test_strings_are_cut_and_padded(tmp_path):
    long_text = "x" * 80
    recs = SCHEMA["MSG"].pack(1, long_text) + SCHEMA["PARM"].pack(2, "A_VERY_LONG_PARAMETER_NAME", 1.5, 2.0)
    r = read_back(tmp_path, SCHEMA.header(0) + recs)
    got = all_messages(r)
    msg = next(m for m in got if m.get_type() == "MSG")
    assert msg.Message == "x" * 64
    parm = next(m for m in got if m.get_type() == "PARM")
    assert parm.Name == "A_VERY_LONG_PARA" and (parm.Value, parm.Default) == (1.5, 2.0)


def test_definitions_are_checked():
    with pytest.raises(ValueError):
        MessageDef("TOOLONG", "Q", "TimeUS", "s", "F")
    with pytest.raises(ValueError):
        MessageDef("X", "QB", "TimeUS", "s-", "F-")          # two formats, one label
    with pytest.raises(ValueError):
        MessageDef("X", "Qx", "TimeUS,A", "s-", "F-")        # unknown character
    with pytest.raises(ValueError):                           # a unit id the table lacks
        Schema([MessageDef("X", "QB", "TimeUS,A", "s@", "F-")], messages.UNITS, messages.MULTS)
    with pytest.raises((TypeError, ValueError)):
        SCHEMA["EV"].pack(1)                                  # too few values
    with pytest.raises((TypeError, ValueError)):
        SCHEMA["MSG"].pack(1)


def test_record_sizes_match_the_fmt_length():
    for name, e in SCHEMA.encoders.items():
        assert e.size == struct.calcsize(e.struct.format), name
    assert SCHEMA["ATT"].size == 28 and SCHEMA["GPS"].size == 51 and SCHEMA["FMT"].size == 89


_float = st.floats(allow_nan=False, allow_infinity=False, width=32, min_value=-1e6, max_value=1e6)
_deg = st.floats(min_value=-180, max_value=180, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(t=st.integers(0, 2**40), roll=_deg, pitch=st.floats(-90, 90), yaw=st.floats(0, 359.99),
       vn=_float, pn=_float, lat=st.floats(-90, 90), lon=st.floats(-180, 180), alt=st.floats(-500, 9000),
       text=st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=64))
def test_round_trip(tmp_path_factory, t, roll, pitch, yaw, vn, pn, lat, lon, alt, text):
    rec = (SCHEMA["XKF1"].pack(t, 0, roll, pitch, yaw, vn, 0.0, 0.0, 0.0, pn, 0.0, 0.0, 0.0, 0.0, 0.0, alt)
           + SCHEMA["POS"].pack(t, lat, lon, alt, 1.0, 2.0)
           + SCHEMA["MSG"].pack(t, text)
           + SCHEMA["MODE"].pack(t, 4, 4, 2))
    got = all_messages(read_back(tmp_path_factory.mktemp("rt"), SCHEMA.header(0) + rec))
    k = next(m for m in got if m.get_type() == "XKF1")
    assert k.TimeUS == t
    assert k.Roll == pytest.approx(roll, abs=0.006) and k.Pitch == pytest.approx(pitch, abs=0.006)
    assert k.Yaw == pytest.approx(yaw, abs=0.006)
    assert k.VN == pytest.approx(vn, rel=1e-6, abs=1e-6) and k.PN == pytest.approx(pn, rel=1e-6, abs=1e-6)
    assert k.OH == pytest.approx(alt, abs=0.006)
    p = next(m for m in got if m.get_type() == "POS")
    assert p.Lat == pytest.approx(lat, abs=1e-7) and p.Lng == pytest.approx(lon, abs=1e-7)
    assert p.Alt == pytest.approx(alt, rel=1e-6, abs=1e-4)
    assert next(m for m in got if m.get_type() == "MSG").Message == text
    mode = next(m for m in got if m.get_type() == "MODE")
    assert (mode.ModeNum, mode.Rsn) == (4, 2) and not math.isnan(p.RelHomeAlt)


_ANY_NUMBER = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64), st.integers(-2**70, 2**70),
                        st.sampled_from([0, 1, 1500, 65535, 65536, -1, 2.5, 3.5, -0.5, True]))


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_a_run_of_records_packs_as_each_record_alone(data):
    """Schema.packer's one struct call gives the bytes of each encoder's careful path joined,
    whatever the values (NaN, infinities, out of range, floats in integer fields)."""
    names = ("ATT", "CTUN", "RCOU", "RCIN", "POS", "XKF1", "GPS", "BAT")
    encs = [SCHEMA[n] for n in names]
    values = [data.draw(st.lists(_ANY_NUMBER, min_size=len(e.d.fmt), max_size=len(e.d.fmt))) for e in encs]
    values[0][0] = data.draw(st.integers(0, 2**64 - 1))           # TimeUS: as the log gives it
    run = SCHEMA.packer(*names)
    try:
        want = b"".join(e._pack_checked(*v) for e, v in zip(encs, values))
    except (OverflowError, struct.error) as refused:      # a float beyond float32: refused alike
        with pytest.raises(type(refused)):
            run(*(x for v in values for x in v))
        return
    assert b"".join(e.pack(*v) for e, v in zip(encs, values)) == want
    assert run(*(x for v in values for x in v)) == want
