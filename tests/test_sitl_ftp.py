"""MAVFTP as ArduPilot's GCS_FTP answers it (vehicle/link/ftp.py): "@PARAM/param.pck" served in
ArduPilot's packed format (decoded here by MAVProxy's own decoder), every other request answered
at once (NAK with ArduPilot's error), so MAVProxy's parameter download never waits on a timeout
(issue 10). MAVProxy runs as a user starts it; its telemetry log (mav.tlog, both directions,
wall-clock stamped) shows the exchange."""
from __future__ import annotations

import os
import struct
import time

import pytest

from support import wait_until
from test_sitl_support import MavProxy, Sitl, connect, mav, recv
from vehicle.link import ftp


def _req(opcode, seq=7, session=0, data=b"", size=None, offset=0):
    size = len(data) if size is None else size
    return (struct.pack("<HBBBBBBI", seq, session, opcode, size, 0, 0, 0, offset) + data).ljust(251, b"\0")


def _hdr(reply):
    return struct.unpack_from("<HBBBBBBI", reply)


@pytest.mark.parametrize("opcode, want", [
    (ftp.OPEN_FILE_RO, (ftp.ERR_FAIL_ERRNO, ftp.ENOENT)),
    (ftp.LIST_DIRECTORY, (ftp.ERR_FAIL_ERRNO, ftp.ENOENT)),
    (ftp.CALC_FILE_CRC32, (ftp.ERR_FAIL_ERRNO, ftp.ENOENT)),
    (ftp.CREATE_FILE, (ftp.ERR_FAIL_ERRNO, ftp.ENOENT)),
    (ftp.READ_FILE, (ftp.ERR_INVALID_SESSION,)),
    (ftp.BURST_READ_FILE, (ftp.ERR_INVALID_SESSION,)),
    (77, (ftp.ERR_UNKNOWN_COMMAND,)),
])
def test_answers_nak_with_arducopters_error(opcode, want):
    reply = ftp.answer(_req(opcode, seq=41, session=3, data=b"@PARAM/param.pck"))
    seq, session, op, size, req_op, _b, _p, _o = _hdr(reply)
    assert (seq, session, op, req_op) == (42, 3, ftp.NAK, opcode)
    assert reply[12:12 + size] == bytes(want)
    assert len(reply) == 251


def test_session_resets_acked_bad_sizes_refused_short_ignored():
    for op in (ftp.TERMINATE_SESSION, ftp.RESET_SESSIONS):
        seq, _s, code, size, req, *_ = _hdr(ftp.answer(_req(op, seq=0xFFFF)))
        assert (seq, code, size, req) == (0, ftp.ACK, 0, op)          # seq wraps
    r = ftp.answer(_req(ftp.OPEN_FILE_RO, size=240))
    assert r[3] == ftp.NAK and r[12] == ftp.ERR_INVALID_DATA_SIZE
    assert ftp.answer(b"\x01\x02\x03") is None
    assert ftp.answer(_req(ftp.NAK)) is None                             # a looped-back reply


def test_param_pck_decodes_with_mavproxys_decoder():
    from MAVProxy.modules.lib.param_ftp import ftp_param_decode
    entries = [("ANGLE_MAX", 3000.0, mav.MAV_PARAM_TYPE_INT16, 3000.0),
               ("ATC_ANG_PIT_P", 4.5, mav.MAV_PARAM_TYPE_REAL32, 4.5),
               ("ATC_ANG_RLL_P", 6.0, mav.MAV_PARAM_TYPE_REAL32, 4.5),
               ("BATT_CAPACITY", 5200.0, mav.MAV_PARAM_TYPE_INT32, 3300.0),
               ("FRAME_CLASS", 1.0, mav.MAV_PARAM_TYPE_INT8, 1.0),
               ("FS_OPTIONS_LONGNAME", -3.0, mav.MAV_PARAM_TYPE_INT8, 0.0)]
    for with_defaults in (False, True):
        d = ftp_param_decode(ftp.param_pck(entries, with_defaults))
        assert [(n.decode(), v, t) for n, v, t in d.params] == [
            ("ANGLE_MAX", 3000, 2), ("ATC_ANG_PIT_P", 4.5, 4), ("ATC_ANG_RLL_P", 6.0, 4),
            ("BATT_CAPACITY", 5200, 3), ("FRAME_CLASS", 1, 1), ("FS_OPTIONS_LONGN", -3, 1)]
        if with_defaults:
            assert [v for _n, v, _t in d.defaults] == [3000, 4.5, 4.5, 3300, 1, 0]


def test_server_reads_a_file_in_bursts_and_chunks():
    content = bytes(range(256)) * 3                       # 768 bytes
    srv = ftp.FtpServer({"@PARAM/param.pck": lambda with_defaults: content})
    (r,) = srv.handle(_req(ftp.OPEN_FILE_RO, seq=1, session=2, data=b"@PARAM/param.pck?withdefaults=1"))
    assert _hdr(r)[2] == ftp.ACK and struct.unpack_from("<I", r, 12)[0] == 768
    (again,) = srv.handle(_req(ftp.OPEN_FILE_RO, seq=2, session=2, data=b"@PARAM/param.pck"))
    assert again[3] == ftp.NAK and again[12] == ftp.ERR_FAIL               # that session is open
    out = srv.handle(_req(ftp.BURST_READ_FILE, seq=3, session=2, size=239))
    data = b"".join(p[12:12 + p[4]] for p in out if p[3] == ftp.ACK)
    assert data == content and [_hdr(p)[7] for p in out[:-1]] == [0, 239, 478, 717]
    assert out[-1][3] == ftp.NAK and out[-1][12] == ftp.ERR_EOF and _hdr(out[-1])[7] == 768
    (r,) = srv.handle(_req(ftp.READ_FILE, seq=4, session=2, size=100, offset=700))
    assert r[12:12 + r[4]] == content[700:768]
    (r,) = srv.handle(_req(ftp.READ_FILE, seq=5, session=2, size=100, offset=768))
    assert r[3] == ftp.NAK and r[12] == ftp.ERR_EOF
    assert srv.handle(_req(ftp.TERMINATE_SESSION, seq=6, session=2))[0][3] == ftp.ACK
    assert srv.handle(_req(ftp.TERMINATE_SESSION, seq=7, session=2))[0][12] == ftp.ERR_INVALID_SESSION
    (r,) = srv.handle(_req(ftp.OPEN_FILE_RO, seq=8, session=0, data=b"/APM/LOGS/1.BIN"))
    assert r[12:14] == bytes([ftp.ERR_FAIL_ERRNO, ftp.ENOENT])


@pytest.mark.timeout(60)
def test_pymavlink_ftp_open_nak_on_the_wire(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    payload = list(_req(ftp.OPEN_FILE_RO, seq=5, data=b"/APM/missing.txt"))
    t0 = time.monotonic()
    m.mav.file_transfer_protocol_send(0, 1, 1, payload)
    r = recv(m, "FILE_TRANSFER_PROTOCOL", 3)
    took = time.monotonic() - t0
    raw = bytes(r.payload)
    assert (r.target_system, r.target_component) == (255, 0)
    assert _hdr(raw)[:5] == (6, 0, ftp.NAK, 2, ftp.OPEN_FILE_RO)
    assert raw[12:14] == bytes([ftp.ERR_FAIL_ERRNO, ftp.ENOENT])
    assert took < 1.0


@pytest.mark.timeout(120)
def test_mavproxy_downloads_parameters_over_mavftp(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    m.mav.param_set_send(1, 1, b"RTL_ALT", 2345, mav.MAV_PARAM_TYPE_INT32)
    pv = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT")
    count = pv.param_count
    m.close()
    # MAVProxy's defaults: the ftp module loaded, param_ftp on: it asks for @PARAM/param.pck first
    t0 = time.monotonic()
    mp = MavProxy(processes, tmp_path, sitl.tcp[0])
    lines, saw = mp.lines, mp.saw
    try:
        wait_until(lambda: saw("Received") and saw("parameters"), 60, "parameters: " + "".join(lines[-5:]))
        took = time.monotonic() - t0
        got = [l for l in lines if "Received" in l and "parameters" in l][-1]
        assert int(got.split("Received")[1].split()[0]) == count and "(ftp)" in got, got
        assert not saw("FTP: retry request")
        # MAVProxy saves what it received (mav.parm) and the defaults (withdefaults=1)
        wait_until(lambda: saw("Saved") and saw("defaults to"), 10, "parameter files saved")
        saved = tmp_path / "mav.parm"
        vals = dict(line.split()[:2] for line in saved.read_text().splitlines() if line.strip()
                    and not line.startswith("#"))
        assert float(vals["RTL_ALT"]) == 2345 and float(vals["FRAME_CLASS"]) == 1
        defaults = tmp_path / "defaults.parm"
        dvals = dict(line.split()[:2] for line in defaults.read_text().splitlines() if line.strip()
                     and not line.startswith("#"))
        assert float(dvals["RTL_ALT"]) == 1500
        mp.send("exit")
    finally:
        processes.stop(mp.proc)
    print(f"MAVProxy start to all {count} parameters over MAVFTP: {took:.2f} s")
    # the tlog: MAVProxy's open of @PARAM/param.pck, our ACK with the file size, no PARAM_VALUE list
    tlogs = [os.path.join(dp, f) for dp, _d, fs in os.walk(tmp_path) for f in fs if f.endswith(".tlog")]
    from pymavlink import mavutil
    log = mavutil.mavlink_connection(max(tlogs, key=os.path.getsize))
    opened = acked = None
    while True:
        msg = log.recv_match(type="FILE_TRANSFER_PROTOCOL")
        if msg is None:
            break
        raw = bytes(msg.payload)
        if raw[3] == ftp.OPEN_FILE_RO and b"@PARAM/param.pck" in raw and opened is None:
            opened = msg._timestamp
        if raw[3] == ftp.ACK and raw[5] == ftp.OPEN_FILE_RO and acked is None:
            acked = msg._timestamp
    assert opened is not None and acked is not None and acked - opened < 0.5
    # (the tlog's PARAM_VALUEs are MAVProxy's own copies of what came over MAVFTP, its log_params)
