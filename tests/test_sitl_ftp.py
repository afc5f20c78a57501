"""MAVFTP: every request answered at once as ArduPilot's GCS_FTP answers it (vehicle/link/ftp.py),
so MAVProxy's parameter download tries "@PARAM/param.pck", is refused and falls back to
PARAM_REQUEST_LIST without waiting on a timeout (issue 10). MAVProxy runs as a user starts it;
its telemetry log (mav.tlog, both directions, wall-clock stamped) shows the exchange."""
from __future__ import annotations

import os
import struct
import subprocess
import sys
import threading
import time

import pytest

from support import wait_until
from test_sitl_mavproxy import MAVPROXY
from test_sitl_support import Sitl, connect, mav, recv
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


@pytest.mark.timeout(60)
def test_pymavlink_ftp_open_nak_on_the_wire(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    payload = list(_req(ftp.OPEN_FILE_RO, seq=5, data=b"@PARAM/param.pck?withdefaults=1"))
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
def test_mavproxy_param_download_does_not_wait_on_mavftp(processes, tmp_path):
    assert os.path.exists(MAVPROXY), f"mavproxy.py not found next to {sys.executable}"
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=2)
    m = connect(sitl.udp[0])
    m.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
    count = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "SYSID_THISMAV").param_count
    m.close()
    # MAVProxy's defaults: the ftp module loaded, param_ftp on (it tries MAVFTP first)
    proxy = processes.start([sys.executable, MAVPROXY, f"--master=tcp:127.0.0.1:{sitl.tcp[0]}",
                             "--state-basedir", str(tmp_path)], stdin=subprocess.PIPE, cwd=str(tmp_path))
    lines: list[str] = []
    threading.Thread(target=lambda: [lines.append(l) for l in proxy.stdout], daemon=True).start()

    def saw(text):
        return any(text in l for l in lines)
    try:
        wait_until(lambda: saw("Received") and saw("parameters"), 60, "parameters: " + "".join(lines[-5:]))
        got = [l for l in lines if "Received" in l and "parameters" in l][-1]
        assert int(got.split("Received")[1].split()[0]) == count, got
        assert "(ftp)" not in got
        assert not saw("FTP: retry request")
        proxy.stdin.write("exit\n")
        proxy.stdin.flush()
    finally:
        processes.stop(proxy)
    # the tlog: MAVProxy's open of @PARAM/param.pck, our NAK, then the PARAM_VALUE stream
    tlogs = [os.path.join(dp, f) for dp, _d, fs in os.walk(tmp_path) for f in fs if f.endswith(".tlog")]
    assert tlogs, os.listdir(tmp_path)
    from pymavlink import mavutil
    log = mavutil.mavlink_connection(max(tlogs, key=os.path.getsize))
    open_t = nak_t = param_t = None
    while True:
        msg = log.recv_match(type=["FILE_TRANSFER_PROTOCOL", "PARAM_VALUE"])
        if msg is None:
            break
        t = msg._timestamp
        if msg.get_type() == "FILE_TRANSFER_PROTOCOL":
            raw = bytes(msg.payload)
            if raw[3] == ftp.OPEN_FILE_RO and b"@PARAM/param.pck" in raw and open_t is None:
                open_t = t
            if raw[3] == ftp.NAK and raw[5] == ftp.OPEN_FILE_RO and nak_t is None:
                nak_t = t
                assert raw[12:14] == bytes([ftp.ERR_FAIL_ERRNO, ftp.ENOENT])
        elif nak_t is not None and param_t is None:
            param_t = t
    assert open_t is not None and nak_t is not None and param_t is not None, (open_t, nak_t, param_t)
    print(f"MAVFTP open -> NAK {nak_t - open_t:.3f} s, NAK -> first PARAM_VALUE {param_t - nak_t:.3f} s")
    assert nak_t - open_t < 0.5
    # MAVProxy's param module checks once a second (param_period) and then asks for the list;
    # a timeout would have cost its FTP retries (retry_time 0.5 s, several of them) first
    assert param_t - nak_t < 1.6
