"""MAVFTP as ArduPilot's GCS_FTP serves it (vehicle/link/ftp.py), with the clients people use,
the way they use them, against one running `towerlink sitl` shared by the module (the root,
its "@" directories, @SYS's files):

- pymavlink's mavftp module (MAVFTP(master, ...).cmd_ftp([...]), process_ftp_reply for get and
  put, as its own command line does);
- MAVProxy as a user starts it, typed into: its parameter download over "@PARAM/param.pck"
  (decoded by MAVProxy's own decoder), then `ftp list /`, `ftp get`, `ftp put`, `ftp crc`;
  its telemetry log (mav.tlog) shows the exchange;
- a raw pymavlink FILE_TRANSFER_PROTOCOL request for a missing file: NAKed at once.

The vehicle's root is <state dir>/vehicles/0 (vehicle/vehicle_root.py); the tests put files
there and read what the clients uploaded from there. MAVSDK's ftp plugin:
tests/test_sitl_mavsdk_ftp.py."""
from __future__ import annotations

import os
import struct
import time

import pytest
from ftp_support import Clock, hdr, req
from support import Processes, wait_until
from test_sitl_support import MavProxy, Sitl, connect, mav, recv

from vehicle.link import ftp
from vehicle.vehicle_root import vehicle_root

pytestmark = pytest.mark.timeout(120)


# ----- the server alone -----------------------------------------------------------------------
@pytest.mark.parametrize("opcode, want", [
    (ftp.OPEN_FILE_RO, (ftp.ERR_FILE_NOT_FOUND,)),
    (ftp.LIST_DIRECTORY, (ftp.ERR_FILE_NOT_FOUND,)),
    (ftp.CALC_FILE_CRC32, (ftp.ERR_FILE_NOT_FOUND,)),
    (ftp.CREATE_FILE, (ftp.ERR_FAIL_ERRNO, 30)),             # EROFS: @PARAM is read-only
    (ftp.READ_FILE, (ftp.ERR_FILE_NOT_FOUND,)),               # no file open
    (ftp.BURST_READ_FILE, (ftp.ERR_FILE_NOT_FOUND,)),
    (77, (ftp.ERR_UNKNOWN_COMMAND,)),
])
def test_answers_nak_with_ardupilots_error(opcode, want):
    srv = ftp.FtpServer({})                                   # no files at all
    (reply,) = srv.handle(req(opcode, seq=41, session=3, data=b"@PARAM/param.pck"))
    seq, session, op, size, req_op, _b, _p, _o = hdr(reply)
    assert (seq, session, op, req_op) == (42, 3, ftp.NAK, opcode)
    assert reply[12:12 + size] == bytes(want)
    assert len(reply) == 251


def test_session_resets_acked_bad_sizes_refused_short_ignored():
    srv = ftp.FtpServer({})
    for op in (ftp.TERMINATE_SESSION, ftp.RESET_SESSIONS):
        seq, _s, code, size, rq, *_ = hdr(srv.handle(req(op, seq=0xFFFF))[0])
        assert (seq, code, size, rq) == (0, ftp.ACK, 0, op)          # seq wraps
    (r,) = srv.handle(req(ftp.OPEN_FILE_RO, seq=3, size=240))
    assert r[3] == ftp.NAK and r[12] == ftp.ERR_INVALID_DATA_SIZE
    assert srv.handle(b"\x01\x02\x03") == []
    assert srv.handle(req(ftp.NAK)) == []                              # a looped-back reply


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
    srv = ftp.FtpServer({"@PARAM/param.pck": lambda with_defaults: content}, clock=Clock())
    (r,) = srv.handle(req(ftp.OPEN_FILE_RO, seq=1, session=2, data=b"@PARAM/param.pck?withdefaults=1"))
    assert hdr(r)[2] == ftp.ACK and struct.unpack_from("<I", r, 12)[0] == 768
    (again,) = srv.handle(req(ftp.OPEN_FILE_RO, seq=2, session=2, data=b"@PARAM/param.pck"))
    assert again[3] == ftp.NAK and again[12] == ftp.ERR_FAIL               # that session is open
    out = srv.handle(req(ftp.BURST_READ_FILE, seq=3, session=2, size=239))
    data = b"".join(p[12:12 + p[4]] for p in out if p[3] == ftp.ACK)
    assert data == content and [hdr(p)[7] for p in out[:-1]] == [0, 239, 478, 717]
    assert out[-1][3] == ftp.NAK and out[-1][12] == ftp.ERR_EOF and hdr(out[-1])[7] == 768
    (r,) = srv.handle(req(ftp.READ_FILE, seq=4, session=2, size=100, offset=700))
    assert r[12:12 + r[4]] == content[700:768]
    (r,) = srv.handle(req(ftp.READ_FILE, seq=5, session=2, size=100, offset=768))
    assert r[3] == ftp.NAK and r[12] == ftp.ERR_EOF
    assert srv.handle(req(ftp.TERMINATE_SESSION, seq=6, session=2))[0][3] == ftp.ACK
    assert srv.handle(req(ftp.TERMINATE_SESSION, seq=7, session=2))[0][3] == ftp.ACK   # ArduPilot: always
    (r,) = srv.handle(req(ftp.READ_FILE, seq=8, session=2, size=100))
    assert r[3] == ftp.NAK and r[12] == ftp.ERR_FILE_NOT_FOUND
    (r,) = srv.handle(req(ftp.OPEN_FILE_RO, seq=9, session=0, data=b"/APM/LOGS/1.BIN"))
    assert r[4] == 1 and r[12] == ftp.ERR_FILE_NOT_FOUND


# ----- one running vehicle --------------------------------------------------------------------
@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    procs = Processes()
    base = tmp_path_factory.mktemp("ftp")
    try:
        s = Sitl(procs, base, drones=1, rovers=0, speedup=2)
        root = vehicle_root(s.state_dir, 0)
        (root / "logs").mkdir(parents=True)
        (root / "logs" / "00000001.BIN").write_bytes(os.urandom(20_000))
        (root / "logs" / "LASTLOG.TXT").write_bytes(b"1\r\n")
        (root / "terrain").mkdir()
        (root.parent.parent / "outside.txt").write_bytes(b"not the vehicle's")
        yield s, root, procs
    finally:
        procs.stop_all()


def test_pymavlink_ftp_open_nak_on_the_wire(sitl):
    s, _root, _procs = sitl
    m = connect(s.udp[0])
    try:
        payload = list(req(ftp.OPEN_FILE_RO, seq=5, session=17, data=b"/APM/missing.txt"))
        t0 = time.monotonic()
        m.mav.file_transfer_protocol_send(0, 1, 1, payload)
        r = recv(m, "FILE_TRANSFER_PROTOCOL", 3)
        took = time.monotonic() - t0
        raw = bytes(r.payload)
        assert (r.target_system, r.target_component) == (255, 0)
        assert hdr(raw)[:5] == (6, 17, ftp.NAK, 1, ftp.OPEN_FILE_RO)
        assert raw[12] == ftp.ERR_FILE_NOT_FOUND
        assert took < 1.0
    finally:
        m.close()


# pymavlink's mavftp takes a reply that has not come within idle_detection_time (1 wall s, below)
# as a failure: with the cores shared by other tests' worlds a rename's answer came later (make test)
@pytest.mark.alone
def test_pymavlinks_mavftp_lists_gets_puts_and_manages_files(sitl, tmp_path):
    from pymavlink import mavftp
    s, root, _procs = sitl
    master = connect(s.udp[0], sysid=246)
    try:
        # its command line's settings (mavftp.py --idle-detection-time ...): after an operation
        # that has no end of its own (crc, mkdir, rm), it waits this long for more replies
        settings = mavftp.MAVFTPSettings([
            ("debug", int, 0), ("pkt_loss_tx", int, 0), ("pkt_loss_rx", int, 0), ("max_backlog", int, 5),
            ("burst_read_size", int, 80), ("write_size", int, 80), ("write_qsize", int, 5),
            ("idle_detection_time", float, 1.0), ("read_retry_time", float, 0.5), ("retry_time", float, 0.5)])
        f = mavftp.MAVFTP(master, target_system=master.target_system, target_component=master.target_component,
                          settings=settings)
        ret = f.cmd_ftp(["list", "/"])
        assert ret.error_code == mavftp.FtpError.Success
        listed = {(e.name, e.is_dir, e.size_b) for e in f.list_result}
        assert {("logs", True, 0), ("terrain", True, 0), ("@SYS", True, 0), ("@MAV_LOG", True, 0)} <= listed
        f.cmd_ftp(["list", "@SYS"])
        assert {("threads.txt", 100000), ("tasks.txt", 100000), ("uarts.txt", 100000), ("storage.bin", 16384)} <= {
            (e.name, e.size_b) for e in f.list_result}
        uarts = tmp_path / "uarts.txt"
        f.cmd_ftp(["get", "@SYS/uarts.txt", str(uarts)])
        assert f.process_ftp_reply("get", timeout=30).error_code == mavftp.FtpError.Success
        text = uarts.read_text()
        assert text.startswith("UARTV1\nSERIAL0 TX=") and " connected     (" in text, text
        assert f.cmd_ftp(["rm", "@SYS/uarts.txt"]).error_code != mavftp.FtpError.Success
        assert f.cmd_ftp(["mkdir", "@SYS/x"]).error_code != mavftp.FtpError.Success
        f.cmd_ftp(["list", "@MAV_LOG"])
        assert ("00000001.BIN", False, 20_000) in {(e.name, e.is_dir, e.size_b) for e in f.list_result}
        assert f.cmd_ftp(["list", "/APM/LOGS"]).error_code == mavftp.FtpError.FileNotFound

        got = tmp_path / "got.bin"
        f.cmd_ftp(["get", "logs/00000001.BIN", str(got)])
        assert f.process_ftp_reply("get", timeout=30).error_code == mavftp.FtpError.Success
        assert got.read_bytes() == (root / "logs" / "00000001.BIN").read_bytes()

        up = tmp_path / "up.lua"
        up.write_bytes(os.urandom(3001))
        f.cmd_ftp(["put", str(up), "terrain/up.lua"])
        assert f.process_ftp_reply("put", timeout=30).error_code == mavftp.FtpError.Success
        wait_until(lambda: (root / "terrain" / "up.lua").read_bytes() == up.read_bytes(), 5, "upload in place")

        assert f.cmd_ftp(["crc", "terrain/up.lua"]).error_code == mavftp.FtpError.Success
        assert f.cmd_ftp(["mkdir", "scripts"]).error_code == mavftp.FtpError.Success
        assert f.cmd_ftp(["mkdir", "scripts"]).error_code == mavftp.FtpError.FileExists
        assert f.cmd_ftp(["rename", "terrain/up.lua", "scripts/up.lua"]).error_code == mavftp.FtpError.Success
        assert (root / "scripts" / "up.lua").read_bytes() == up.read_bytes()
        assert f.cmd_ftp(["rm", "scripts/up.lua"]).error_code == mavftp.FtpError.Success
        assert f.cmd_ftp(["rmdir", "scripts"]).error_code == mavftp.FtpError.Success
        assert not (root / "scripts").exists()
        assert f.cmd_ftp(["rm", "../../outside.txt"]).error_code == mavftp.FtpError.FileNotFound
        assert os.path.exists(os.path.join(s.state_dir, "outside.txt"))
        params = f.read("@PARAM/param.pck", 100)               # the synchronous read API
        assert len(params) == 100 and struct.unpack_from("<H", params)[0] == ftp.PCK_MAGIC
    finally:
        master.close()


@pytest.fixture(scope="module")
def mavproxy(sitl, tmp_path_factory):
    s, _root, procs = sitl
    m = connect(s.udp[0])
    m.mav.param_set_send(1, 1, b"RTL_ALT", 2345, mav.MAV_PARAM_TYPE_INT32)
    count = recv(m, "PARAM_VALUE", 5, cond=lambda p: p.param_id == "RTL_ALT").param_count
    m.close()
    home = tmp_path_factory.mktemp("mavproxy")
    # MAVProxy's defaults: the ftp module loaded, param_ftp on: it asks for @PARAM/param.pck first
    t0 = time.monotonic()
    mp = MavProxy(procs, home, s.tcp[0])
    try:
        yield mp, home, count, t0
        mp.send("exit")
    finally:
        procs.stop(mp.proc)


@pytest.mark.alone          # its open-to-ACK bound is wall time, read from MAVProxy's tlog
def test_mavproxy_downloads_parameters_over_mavftp(mavproxy):
    mp, home, count, t0 = mavproxy
    lines, saw = mp.lines, mp.saw
    wait_until(lambda: saw("Received") and saw("parameters"), 60, "parameters: " + "".join(lines[-5:]))
    took = time.monotonic() - t0
    got = [l for l in lines if "Received" in l and "parameters" in l][-1]
    assert int(got.split("Received")[1].split()[0]) == count and "(ftp)" in got, got
    assert not saw("FTP: retry request")
    # MAVProxy saves what it received (mav.parm) and the defaults (withdefaults=1)
    wait_until(lambda: saw("Saved") and saw("defaults to"), 10, "parameter files saved")
    vals = dict(line.split()[:2] for line in (home / "mav.parm").read_text().splitlines() if line.strip()
                and not line.startswith("#"))
    assert float(vals["RTL_ALT"]) == 2345 and float(vals["FRAME_CLASS"]) == 1
    dvals = dict(line.split()[:2] for line in (home / "defaults.parm").read_text().splitlines() if line.strip()
                 and not line.startswith("#"))
    assert float(dvals["RTL_ALT"]) == 1500
    print(f"MAVProxy start to all {count} parameters over MAVFTP: {took:.2f} s")
    # the tlog: MAVProxy's open of @PARAM/param.pck, our ACK with the file size
    tlogs = [os.path.join(dp, f) for dp, _d, fs in os.walk(home) for f in fs if f.endswith(".tlog")]
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


def _typed(mp, command: str, done: str, timeout: float = 30.0) -> list[str]:
    """Type a command into MAVProxy; the lines it printed until one contains `done`."""
    start = len(mp.lines)
    mp.send(command)
    wait_until(lambda: any(done in l for l in mp.lines[start:]), timeout,
               f"{command!r}: " + "".join(mp.lines[start:])[-1500:])
    return mp.lines[start:]


def test_mavproxy_ftp_list_get_put_crc(mavproxy, sitl):
    mp, home, _count, _t0 = mavproxy
    _s, root, _procs = sitl
    wait_until(lambda: mp.saw("Saved") and mp.saw("defaults to"), 60, "MAVProxy ready")
    out = "".join(_typed(mp, "ftp list /", "Total size"))
    for entry in (" D logs", " D terrain", " D @SYS", " D @MAV_LOG"):
        assert entry + "\n" in out, out
    out = "".join(_typed(mp, "ftp list @SYS", "Total size"))
    assert "   threads.txt\t100000\n" in out and "   uarts.txt\t100000\n" in out, out
    out = "".join(_typed(mp, "ftp list logs", "Total size"))
    assert "   00000001.BIN\t20000" in out and "   LASTLOG.TXT\t3" in out, out

    got = home / "copy.bin"
    _typed(mp, f"ftp get logs/00000001.BIN {got}", "Wrote 20000 bytes")
    assert got.read_bytes() == (root / "logs" / "00000001.BIN").read_bytes()

    up = home / "mission.lua"
    up.write_bytes(os.urandom(5000))
    _typed(mp, f"ftp put {up} terrain/mission.lua", "Sent file of length 5000")
    wait_until(lambda: (root / "terrain" / "mission.lua").exists()
               and (root / "terrain" / "mission.lua").read_bytes() == up.read_bytes(), 10, "upload in place")
    out = "".join(_typed(mp, "ftp crc terrain/mission.lua", "crc: "))
    from ftp_support import crc32_bitwise
    assert f"0x{crc32_bitwise(up.read_bytes()):08x}" in out, out
