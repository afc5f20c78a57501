"""The MAVFTP server on its own (vehicle/link/ftp.py over vehicle/files/): every opcode with
ArduPilot's ACK/NAK and error bytes, directory listings in GCS_FTP's format, bursts, staged
uploads, sessions and their timeouts, retransmissions. Bytes in, bytes out: no sockets; a
settable clock stands for the wall clock."""
from __future__ import annotations

import errno
import itertools
import os
import struct

import pytest
from ftp_support import Clock, body, crc32_bitwise, hdr, nak_of, req
from hypothesis import given, settings
from hypothesis import strategies as st

from vehicle.files import sys_dir
from vehicle.link import ftp

PARAMS = bytes(range(256)) * 3            # 768 bytes standing for @PARAM/param.pck


@pytest.fixture
def clock():
    return Clock()


@pytest.fixture
def root(tmp_path):
    r = tmp_path / "vehicles" / "0"
    (r / "logs").mkdir(parents=True)
    (r / "logs" / "00000001.BIN").write_bytes(os.urandom(1000))
    (r / "logs" / "LASTLOG.TXT").write_bytes(b"1\r\n")
    (r / "scripts").mkdir()
    (r / "notes.txt").write_bytes(b"hello")
    return r


@pytest.fixture
def srv(root, clock):
    return ftp.FtpServer({"@PARAM/param.pck": lambda with_defaults: PARAMS[:700 if with_defaults else 768]},
                         root=root, clock=clock)


_SEQ = itertools.count(1000)


def one(srv, opcode, sysid=255, compid=190, channel="udp", **kw):
    """The one reply to a request; seq, unless given, is new (an old one would be taken for a
    retransmission and answered from the reply cache)."""
    kw.setdefault("seq", next(_SEQ))
    out = srv.handle(req(opcode, **kw), sysid, compid, channel)
    assert len(out) == 1, [hdr(r) for r in out]
    return out[0]


def ok(reply):
    assert reply[3] == ftp.ACK, f"NAK {tuple(body(reply))}"
    return reply


def listing(srv, path, **kw):
    """Every entry of a directory, paging by offset as clients do; and the pages' raw bodies."""
    entries, pages, offset = [], [], 0
    while True:
        r = one(srv, ftp.LIST_DIRECTORY, data=path, offset=offset, **kw)
        if r[3] == ftp.NAK:
            assert nak_of(r) == (ftp.ERR_EOF,) and hdr(r)[7] == offset
            return entries, pages
        assert hdr(r)[7] == offset
        pages.append(body(r))
        got = body(r).split(b"\0")
        assert got[-1] == b"" and b"" not in got[:-1]             # one NUL after each entry
        entries += got[:-1]
        offset += len(got) - 1


# ----- listing --------------------------------------------------------------------------------
def test_root_listing_is_ardupilots_sitl_listing(srv):
    # the root directory's entries, then the "@" directories AP_Filesystem::readdir appends
    # in its backend table's order (those it can opendir: not @PARAM, not @MISSION)
    entries, pages = listing(srv, b"/")
    assert entries == [b"D.", b"D..", b"Dlogs", b"Fnotes.txt\t5", b"Dscripts", b"D@SYS", b"D@MAV_LOG"]
    assert pages == [b"D.\0D..\0Dlogs\0Fnotes.txt\t5\0Dscripts\0D@SYS\0D@MAV_LOG\0"]
    for alias in (b"logs", b"/logs/", b"./logs", b"@MAV_LOG", b"/@MAV_LOG"):
        assert listing(srv, alias)[0] == [b"D.", b"D..", b"F00000001.BIN\t1000", b"FLASTLOG.TXT\t3"], alias


def test_listing_pages_fit_239_bytes_and_skip_what_never_fits(srv, root):
    names = [f"{i:03d}_" + "x" * (i % 40) for i in range(60)]
    for n in names:
        (root / "scripts" / n).write_bytes(b"z" * n.count("x"))
    (root / "scripts" / ("L" * 250)).write_bytes(b"")           # "F" + 250 + "\t0" + NUL > 239
    entries, pages = listing(srv, b"scripts")
    assert entries == [b"D.", b"D.."] + [f"F{n}\t{n.count('x')}".encode() for n in names]
    assert len(pages) > 5 and all(len(p) < 239 for p in pages)
    # each page holds as many entries as fit: the next one would not have
    for p, nxt in zip(pages, entries_after_pages(pages, entries)):
        assert len(p) + len(nxt) + 1 >= 239
    assert one(srv, ftp.LIST_DIRECTORY, data=b"scripts", offset=len(entries))[3] == ftp.NAK


def entries_after_pages(pages, entries):
    at = 0
    for p in pages[:-1]:
        at += p.count(b"\0")
        yield entries[at]


def test_listing_errors(srv):
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"/APM/LOGS")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"notes.txt")) == (ftp.ERR_FAIL_ERRNO, errno.ENOTDIR)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@PARAM")) == (ftp.ERR_FILE_NOT_FOUND,)  # no opendir
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@SYS/threads.txt")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@SYS/.")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@ROMFS")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@MISSION")) == (ftp.ERR_FILE_NOT_FOUND,)
    r = one(srv, ftp.LIST_DIRECTORY, data=b"logs", size=9, offset=3)
    assert nak_of(r) == (ftp.ERR_INVALID_DATA_SIZE,) and hdr(r)[7] == 3


def test_logs_alias_listed_only_when_the_log_directory_exists(srv, root):
    (root / "logs" / "00000001.BIN").unlink()
    (root / "logs" / "LASTLOG.TXT").unlink()
    (root / "logs").rmdir()
    assert listing(srv, b"/")[0][-2:] == [b"Dscripts", b"D@SYS"]
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"@MAV_LOG")) == (ftp.ERR_FILE_NOT_FOUND,)


# ----- @SYS -----------------------------------------------------------------------------------
SYS_LISTING = [b"Fthreads.txt\t100000", b"Ftasks.txt\t100000", b"Fdma.txt\t100000", b"Fmemory.txt\t100000",
               b"Fuarts.txt\t100000", b"Ftimers.txt\t100000", b"Fcan0_stats.txt\t100000",
               b"Fcan1_stats.txt\t100000", b"Fstorage.bin\t16384"]


def test_sys_lists_sitls_files_in_ardupilots_order(srv):
    for path in (b"@SYS", b"/@SYS", b"@SYS/", b"/@SYS/"):
        assert listing(srv, path)[0] == SYS_LISTING, path


def _read_all(srv, path, session):
    r = ok(one(srv, ftp.OPEN_FILE_RO, session=session, data=path))
    size, data = struct.unpack("<I", body(r))[0], b""
    while True:
        r = one(srv, ftp.READ_FILE, session=session, size=239, offset=len(data))
        if r[3] == ftp.NAK:
            assert nak_of(r) == (ftp.ERR_EOF,)
            ok(one(srv, ftp.TERMINATE_SESSION, session=session))
            return size, data
        data += body(r)


def test_sys_files_read_as_sitl_gives_them(root, clock):
    ports = [sys_dir.Port("tcpin:0.0.0.0:5760", True, 1000, 200), sys_dir.Port("udpin:0.0.0.0:14550", False, 0, 0)]
    ms = [5000]
    srv = ftp.FtpServer({}, root=root, clock=clock, sys_dir=sys_dir.SysDir(lambda: ports, lambda: ms[0]))
    # OpenFileRO's ACK gives stat's size, the reads end where the content does
    size, text = _read_all(srv, b"@SYS/uarts.txt", 1)
    assert size == 100000
    assert text.decode() == ("UARTV1\n"
                             "SERIAL0 TX=    1000 RX=     200 TXBD=   200 RXBD=    40 connected     (tcpin:0.0.0.0:5760)\n"
                             "SERIAL1 TX=       0 RX=       0 TXBD=     0 RXBD=     0 not connected (udpin:0.0.0.0:14550)\n")
    # the next read reports what moved since this one
    ports[0] = sys_dir.Port("tcpin:0.0.0.0:5760", True, 1500, 300)
    ms[0] = 7000
    text = _read_all(srv, b"/@SYS/uarts.txt", 1)[1].decode()
    assert "SERIAL0 TX=     500 RX=     100 TXBD=   250 RXBD=    50 connected " in text, text
    assert _read_all(srv, b"@SYS/tasks.txt", 2) == (100000, b"TasksV2\n")
    assert _read_all(srv, b"@SYS/storage.bin", 2) == (16384, bytes(16384))
    crc = struct.unpack("<I", body(ok(one(srv, ftp.CALC_FILE_CRC32, session=3, data=b"@SYS/tasks.txt"))))[0]
    assert crc == crc32_bitwise(b"TasksV2\n")
    # SITL's HAL reports no threads, DMA, memory or timers and has no CAN interface: empty
    for name in (b"threads.txt", b"dma.txt", b"memory.txt", b"timers.txt", b"can0_stats.txt", b"nothing.txt"):
        assert nak_of(one(srv, ftp.OPEN_FILE_RO, session=4, data=b"@SYS/" + name)) == (ftp.ERR_FILE_NOT_FOUND,)


def test_sys_is_read_only(srv, root):
    (root / "@SYS").mkdir()                      # a real directory of that name stays shadowed
    for op, path in ((ftp.CREATE_FILE, b"@SYS/uarts.txt"), (ftp.OPEN_FILE_WO, b"@SYS/tasks.txt"),
                     (ftp.CREATE_FILE, b"@SYS/new.txt"), (ftp.REMOVE_FILE, b"@SYS/uarts.txt"),
                     (ftp.REMOVE_DIRECTORY, b"@SYS"), (ftp.CREATE_DIRECTORY, b"@SYS/dir"),
                     (ftp.TRUNCATE_FILE, b"@SYS/storage.bin")):
        assert nak_of(one(srv, op, session=5, data=path)) == (ftp.ERR_FAIL_ERRNO, errno.EROFS), (op, path)
    assert nak_of(one(srv, ftp.RENAME, session=5, data=b"@SYS/uarts.txt\0notes2.txt")) == (ftp.ERR_FAIL_ERRNO,
                                                                                          errno.EROFS)
    assert nak_of(one(srv, ftp.RENAME, session=5, data=b"notes.txt\0@SYS/notes.txt")) == (ftp.ERR_FAIL_ERRNO,
                                                                                         errno.EROFS)
    assert (root / "notes.txt").read_bytes() == b"hello" and os.listdir(root / "@SYS") == []
    assert listing(srv, b"@SYS")[0] == SYS_LISTING


# ----- reading --------------------------------------------------------------------------------
def test_open_read_and_burst_a_log(srv, root):
    content = (root / "logs" / "00000001.BIN").read_bytes()
    r = ok(one(srv, ftp.OPEN_FILE_RO, seq=10, session=7, data=b"@MAV_LOG/00000001.BIN"))
    assert hdr(r)[:5] == (11, 7, ftp.ACK, 4, ftp.OPEN_FILE_RO) and struct.unpack("<I", body(r)) == (1000,)
    r = ok(one(srv, ftp.READ_FILE, seq=11, session=7, size=239, offset=900))
    assert body(r) == content[900:] and hdr(r)[7] == 900
    assert nak_of(one(srv, ftp.READ_FILE, seq=12, session=7, size=239, offset=1000)) == (ftp.ERR_EOF,)
    out = srv.handle(req(ftp.BURST_READ_FILE, seq=13, session=7, size=80, offset=160), 255, 190, "udp")
    acks, last = out[:-1], out[-1]
    assert b"".join(body(p) for p in acks) == content[160:]
    assert [hdr(p)[0] for p in out] == list(range(14, 14 + len(out)))          # seq steps per packet
    assert [hdr(p)[7] for p in acks] == list(range(160, 1000, 80))
    assert all(hdr(p)[5] == 0 for p in acks)
    assert nak_of(last) == (ftp.ERR_EOF,) and hdr(last)[5] == 1 and hdr(last)[7] == 1000


def test_a_burst_stops_at_burst_packets_with_burst_complete(srv, root):
    (root / "big.bin").write_bytes(os.urandom(100 * 239))
    ok(one(srv, ftp.OPEN_FILE_RO, session=1, data=b"big.bin"))
    out = srv.handle(req(ftp.BURST_READ_FILE, seq=2, session=1, size=0), 255, 190, "udp")
    assert len(out) == srv.BURST_PACKETS and all(p[3] == ftp.ACK and p[4] == 239 for p in out)
    assert [hdr(p)[5] for p in out] == [0] * (srv.BURST_PACKETS - 1) + [1]


def test_reads_need_a_file_open_for_reading(srv, clock):
    assert nak_of(one(srv, ftp.READ_FILE, session=3, size=10)) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.BURST_READ_FILE, seq=2, session=3)) == (ftp.ERR_FILE_NOT_FOUND,)
    ok(one(srv, ftp.CREATE_FILE, seq=3, session=3, data=b"new.txt"))
    assert nak_of(one(srv, ftp.READ_FILE, seq=4, session=3, size=10)) == (ftp.ERR_FAIL,)
    assert nak_of(one(srv, ftp.BURST_READ_FILE, seq=5, session=3)) == (ftp.ERR_FAIL,)
    ok(one(srv, ftp.OPEN_FILE_RO, seq=6, session=4, data=b"logs"))                   # a directory opens,
    assert nak_of(one(srv, ftp.READ_FILE, seq=7, session=4, size=10)) == (ftp.ERR_FAIL_ERRNO, errno.EISDIR)


def test_one_open_file_per_session_and_a_stale_open_is_replaced(srv, clock):
    ok(one(srv, ftp.OPEN_FILE_RO, seq=1, session=2, data=b"notes.txt"))
    assert nak_of(one(srv, ftp.OPEN_FILE_RO, seq=3, session=2, data=b"notes.txt")) == (ftp.ERR_FAIL,)
    assert nak_of(one(srv, ftp.CREATE_FILE, seq=5, session=2, data=b"x")) == (ftp.ERR_FAIL,)
    clock.t += 3.5                        # the client lost our ACK and gave up: open afresh
    r = ok(one(srv, ftp.OPEN_FILE_RO, seq=7, session=2, data=b"logs/LASTLOG.TXT"))
    assert body(r) == struct.pack("<I", 3)
    assert body(ok(one(srv, ftp.READ_FILE, seq=8, session=2, size=50))) == b"1\r\n"


def test_param_pck_is_a_read_only_virtual_file(srv):
    r = ok(one(srv, ftp.OPEN_FILE_RO, session=1, data=b"@PARAM/param.pck?withdefaults=1"))
    assert body(r) == struct.pack("<I", 700)
    ok(one(srv, ftp.TERMINATE_SESSION, seq=2, session=1))
    assert body(ok(one(srv, ftp.OPEN_FILE_RO, seq=3, session=1, data=b"/@PARAM/param.pck"))) == struct.pack("<I", 768)
    assert crc32_bitwise(PARAMS) == struct.unpack("<I", body(ok(one(srv, ftp.CALC_FILE_CRC32, seq=5, session=2,
                                                                      data=b"@PARAM/param.pck"))))[0]
    for op in (ftp.CREATE_FILE, ftp.OPEN_FILE_WO, ftp.REMOVE_FILE, ftp.CREATE_DIRECTORY, ftp.TRUNCATE_FILE):
        assert nak_of(one(srv, op, seq=10 + op, session=3, data=b"@PARAM/param.pck")) == (ftp.ERR_FAIL_ERRNO, errno.EROFS)
    assert nak_of(one(srv, ftp.OPEN_FILE_RO, seq=40, session=4, data=b"@PARAM/other")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.CREATE_DIRECTORY, seq=41, session=4, data=b"@SYS")) == (ftp.ERR_FAIL_ERRNO, errno.EROFS)


# ----- writing --------------------------------------------------------------------------------
def test_an_upload_replaces_the_file_whole_when_the_session_closes(srv, root):
    target = root / "scripts" / "mission.lua"
    target.write_bytes(b"old content")
    ok(one(srv, ftp.CREATE_FILE, seq=1, session=5, data=b"/scripts/mission.lua"))
    for k, at in enumerate(range(0, 600, 200)):                # out of order is fine
        r = ok(one(srv, ftp.WRITE_FILE, seq=2 + k, session=5, data=bytes([65 + k]) * 200, offset=600 - 200 - at))
        assert hdr(r)[3] == 0 and hdr(r)[7] == 400 - at
    assert target.read_bytes() == b"old content"             # nothing in place before the close
    ok(one(srv, ftp.TERMINATE_SESSION, seq=9, session=5))
    assert target.read_bytes() == b"C" * 200 + b"B" * 200 + b"A" * 200
    assert sorted(os.listdir(root / "scripts")) == ["mission.lua"]
    # OpenFileWO starts from the file as it is
    ok(one(srv, ftp.OPEN_FILE_WO, seq=10, session=5, data=b"scripts/mission.lua"))
    ok(one(srv, ftp.WRITE_FILE, seq=11, session=5, data=b"xyz", offset=1))
    ok(one(srv, ftp.RESET_SESSIONS, seq=12, session=0))      # every close puts it in place
    assert target.read_bytes()[:5] == b"CxyzC" and len(target.read_bytes()) == 600


def test_a_new_file_appears_at_once_and_a_crash_keeps_the_old_content(root, clock):
    (root / "notes.txt").write_bytes(b"saved before")
    srv = ftp.FtpServer({}, root=root, clock=clock)
    ok(srv.handle(req(ftp.CREATE_FILE, seq=1, session=1, data=b"notes.txt"))[0])
    ok(srv.handle(req(ftp.WRITE_FILE, seq=2, session=1, data=b"half an upl"))[0])
    ok(srv.handle(req(ftp.CREATE_FILE, seq=3, session=2, data=b"fresh.txt"))[0])
    assert (root / "fresh.txt").read_bytes() == b""           # created empty, as in place
    del srv                                                   # the process dies: nothing closed
    assert (root / "notes.txt").read_bytes() == b"saved before"
    staging = root.parent / ".0.partial"
    assert len(os.listdir(staging)) == 2                       # what the crash left, outside the root
    ftp.FtpServer({}, root=root, clock=clock)                 # the next start clears it
    assert os.listdir(staging) == []


def test_write_errors(srv, root):
    assert nak_of(one(srv, ftp.WRITE_FILE, session=1, data=b"x")) == (ftp.ERR_FILE_NOT_FOUND,)
    ok(one(srv, ftp.OPEN_FILE_RO, seq=2, session=1, data=b"notes.txt"))
    assert nak_of(one(srv, ftp.WRITE_FILE, seq=3, session=1, data=b"x")) == (ftp.ERR_FAIL,)
    assert nak_of(one(srv, ftp.CREATE_FILE, seq=4, session=2, data=b"nodir/x")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.CREATE_FILE, seq=5, session=2, data=b"logs")) == (ftp.ERR_FAIL_ERRNO, errno.EISDIR)
    assert nak_of(one(srv, ftp.CREATE_FILE, seq=6, session=2, data=b"/")) == (ftp.ERR_FAIL_ERRNO, errno.EISDIR)
    assert nak_of(one(srv, ftp.OPEN_FILE_WO, seq=7, session=2, data=b"notes.txt/x")) == (ftp.ERR_FAIL_ERRNO, errno.ENOTDIR)
    assert not (root / "nodir").exists()


def test_truncate_cuts_the_file_at_offset(srv, root):
    ok(one(srv, ftp.TRUNCATE_FILE, data=b"notes.txt", offset=2))
    assert (root / "notes.txt").read_bytes() == b"he"
    assert nak_of(one(srv, ftp.TRUNCATE_FILE, seq=3, data=b"missing", offset=0)) == (ftp.ERR_FILE_NOT_FOUND,)


# ----- directories, remove, rename, CRC -------------------------------------------------------
def test_make_and_remove_directories_and_files(srv, root):
    ok(one(srv, ftp.CREATE_DIRECTORY, seq=1, data=b"/terrain"))
    assert (root / "terrain").is_dir() and (os.stat(root / "terrain").st_mode & 0o700) == 0o700
    assert nak_of(one(srv, ftp.CREATE_DIRECTORY, seq=3, data=b"terrain")) == (ftp.ERR_FILE_EXISTS,)
    assert nak_of(one(srv, ftp.CREATE_DIRECTORY, seq=5, data=b"a/b")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.CREATE_DIRECTORY, seq=7, data=b"/")) == (ftp.ERR_FILE_EXISTS,)
    ok(one(srv, ftp.REMOVE_FILE, seq=9, data=b"terrain"))                # rmdir, then unlink
    assert not (root / "terrain").exists()
    ok(one(srv, ftp.REMOVE_DIRECTORY, seq=11, data=b"notes.txt"))         # and the other way round
    assert not (root / "notes.txt").exists()
    assert nak_of(one(srv, ftp.REMOVE_DIRECTORY, seq=13, data=b"logs")) == (ftp.ERR_FAIL_ERRNO, errno.EISDIR)
    assert nak_of(one(srv, ftp.REMOVE_FILE, seq=15, data=b"gone")) == (ftp.ERR_FILE_NOT_FOUND,)
    for path in (b"/", b".", b"logs/..", b"@MAV_LOG/.."):
        assert nak_of(one(srv, ftp.REMOVE_DIRECTORY, data=path)) == (ftp.ERR_FAIL_ERRNO, errno.EACCES)
    assert root.is_dir()


def test_rename(srv, root):
    ok(one(srv, ftp.RENAME, data=b"notes.txt\0scripts/n.txt"))
    assert (root / "scripts" / "n.txt").read_bytes() == b"hello" and not (root / "notes.txt").exists()
    ok(one(srv, ftp.RENAME, seq=3, data=b"scripts\0lua\0", size=12))             # + a closing NUL
    assert (root / "lua" / "n.txt").exists()
    assert nak_of(one(srv, ftp.RENAME, seq=5, data=b"nope\0x")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.RENAME, seq=7, data=b"lua\0x", size=4)) == (ftp.ERR_INVALID_DATA_SIZE,)
    assert nak_of(one(srv, ftp.RENAME, seq=9, data=b"lua", size=3)) == (ftp.ERR_INVALID_DATA_SIZE,)
    assert nak_of(one(srv, ftp.RENAME, seq=11, data=b"/\0x")) == (ftp.ERR_FAIL_ERRNO, errno.EACCES)


def test_crc32_is_ardupilots(srv, root):
    data = os.urandom(5000)
    (root / "blob").write_bytes(data)
    r = ok(one(srv, ftp.CALC_FILE_CRC32, data=b"blob"))
    assert hdr(r)[3] == 4 and struct.unpack("<I", body(r))[0] == crc32_bitwise(data)
    assert struct.unpack("<I", body(ok(one(srv, ftp.CALC_FILE_CRC32, seq=3, data=b"notes.txt"))))[0] == 0xF032519B
    assert nak_of(one(srv, ftp.CALC_FILE_CRC32, seq=5, data=b"none")) == (ftp.ERR_FILE_NOT_FOUND,)
    assert nak_of(one(srv, ftp.CALC_FILE_CRC32, seq=7, data=b"logs")) == (ftp.ERR_FAIL_ERRNO, errno.EISDIR)


# ----- request checks -------------------------------------------------------------------------
@pytest.mark.parametrize("opcode", [ftp.LIST_DIRECTORY, ftp.OPEN_FILE_RO, ftp.CREATE_FILE, ftp.OPEN_FILE_WO,
                                    ftp.CREATE_DIRECTORY, ftp.REMOVE_FILE, ftp.REMOVE_DIRECTORY,
                                    ftp.CALC_FILE_CRC32, ftp.TRUNCATE_FILE])
def test_name_sizes_as_check_name_len(srv, opcode):
    assert nak_of(one(srv, opcode, data=b"", size=0)) == (ftp.ERR_INVALID_DATA_SIZE,)
    assert nak_of(one(srv, opcode, seq=3, data=b"notes.txt", size=4)) == (ftp.ERR_INVALID_DATA_SIZE,)
    assert nak_of(one(srv, opcode, seq=5, data=b"notes\0txt")) == (ftp.ERR_INVALID_DATA_SIZE,)   # a NUL inside
    assert nak_of(one(srv, opcode, seq=7, data=b"n", size=240)) == (ftp.ERR_INVALID_DATA_SIZE,)
    r = one(srv, opcode, seq=9, session=9, data=b"missing/\0", size=9)                           # len + 1: fine
    assert r[3] == ftp.ACK or nak_of(r) != (ftp.ERR_INVALID_DATA_SIZE,)


def test_a_full_length_name_loses_its_last_byte(srv, root):
    (root / ("a" * 238)).write_bytes(b"238")                 # GCS_FTP zeroes data[238]
    r = ok(one(srv, ftp.OPEN_FILE_RO, data=b"a" * 238 + b"X"))
    assert struct.unpack("<I", body(r)) == (3,)


def test_other_opcodes_acks_naks_and_garbage(srv):
    assert hdr(ok(one(srv, ftp.NONE, seq=0xFFFF)))[:5] == (0, 0, ftp.ACK, 0, ftp.NONE)     # seq wraps
    assert nak_of(one(srv, 16, seq=2, data=b"/")) == (ftp.ERR_UNKNOWN_COMMAND,)           # ListDirectoryWithTime
    assert nak_of(one(srv, 77, seq=3)) == (ftp.ERR_UNKNOWN_COMMAND,)
    assert srv.handle(req(ftp.ACK)) == [] and srv.handle(req(ftp.NAK)) == []
    assert srv.handle(b"\x01\x02\x03") == []
    r = one(srv, ftp.RESET_SESSIONS, seq=4, session=9)
    assert hdr(r)[:5] == (5, 9, ftp.ACK, 0, ftp.RESET_SESSIONS) and len(r) == 251


def test_a_server_without_a_root_serves_only_its_virtual_files(clock):
    srv = ftp.FtpServer({"@PARAM/param.pck": lambda d: PARAMS}, clock=clock)
    for op in (ftp.LIST_DIRECTORY, ftp.OPEN_FILE_RO, ftp.CALC_FILE_CRC32, ftp.CREATE_FILE, ftp.CREATE_DIRECTORY,
               ftp.REMOVE_FILE):
        assert nak_of(one(srv, op, seq=op, data=b"/")) in ((ftp.ERR_FILE_NOT_FOUND,),), op
    ok(one(srv, ftp.OPEN_FILE_RO, seq=50, data=b"@PARAM/param.pck"))


# ----- sessions -------------------------------------------------------------------------------
def test_five_sessions_then_none_until_one_goes_quiet(srv, clock):
    for s in range(1, 6):
        ok(one(srv, ftp.OPEN_FILE_RO, seq=s, session=s, data=b"notes.txt"))
        clock.t += 0.1
    assert nak_of(one(srv, ftp.OPEN_FILE_RO, seq=9, session=6, data=b"notes.txt")) == (ftp.ERR_NO_SESSIONS,)
    ok(one(srv, ftp.READ_FILE, seq=10, session=1, size=5))            # session 1 stays busy
    clock.t += 2.0
    assert nak_of(one(srv, ftp.NONE, seq=11, session=6)) == (ftp.ERR_NO_SESSIONS,)
    clock.t += 1.0                                                  # session 2 quiet for 3.4 s now
    ok(one(srv, ftp.OPEN_FILE_RO, seq=12, session=6, data=b"notes.txt"))
    # session 2's slot is gone: its next request claims the quiet session 3's slot, no file open
    assert nak_of(one(srv, ftp.READ_FILE, seq=13, session=2, size=5)) == (ftp.ERR_FILE_NOT_FOUND,)
    ok(one(srv, ftp.READ_FILE, seq=14, session=1, size=5))


def test_terminate_frees_a_slot_at_once(srv, clock):
    for s in range(1, 6):
        ok(one(srv, ftp.NONE, seq=s, session=s))
    assert nak_of(one(srv, ftp.NONE, seq=8, session=6)) == (ftp.ERR_NO_SESSIONS,)
    ok(one(srv, ftp.TERMINATE_SESSION, seq=9, session=4))
    ok(one(srv, ftp.NONE, seq=10, session=6))
    ok(one(srv, ftp.TERMINATE_SESSION, seq=11, session=6))
    ok(one(srv, ftp.TERMINATE_SESSION, seq=13, session=6))           # nothing open: still ACKed


def test_sessions_are_per_requester_and_idle_ones_die_after_20_s(srv, clock):
    ok(one(srv, ftp.OPEN_FILE_RO, seq=1, session=1, data=b"notes.txt", sysid=255))
    ok(one(srv, ftp.OPEN_FILE_RO, seq=1, session=1, data=b"notes.txt", sysid=254))   # same byte, another GCS
    ok(one(srv, ftp.RESET_SESSIONS, seq=3, sysid=254))
    assert nak_of(one(srv, ftp.READ_FILE, seq=4, session=1, size=5, sysid=254)) == (ftp.ERR_FILE_NOT_FOUND,)
    ok(one(srv, ftp.READ_FILE, seq=5, session=1, size=5, sysid=255))
    ok(one(srv, ftp.OPEN_FILE_RO, seq=6, session=1, data=b"notes.txt", sysid=255, channel="tcp"))
    clock.t += 20.5
    assert nak_of(one(srv, ftp.READ_FILE, seq=7, session=1, size=5, sysid=255)) == (ftp.ERR_FILE_NOT_FOUND,)


def test_a_retransmitted_request_gets_the_same_reply(srv, root):
    first = one(srv, ftp.CREATE_FILE, seq=20, session=3, data=b"up.txt")
    assert one(srv, ftp.CREATE_FILE, seq=20, session=3, data=b"up.txt") == first          # not "already open"
    w = one(srv, ftp.WRITE_FILE, seq=21, session=3, data=b"abc")
    assert one(srv, ftp.WRITE_FILE, seq=21, session=3, data=b"abc") == w
    one(srv, ftp.TERMINATE_SESSION, seq=22, session=3)
    assert (root / "up.txt").read_bytes() == b"abc"
    # a burst that ends at once (one data packet, then EOF): the next request with the seq the
    # EOF carried is a new one, not a retransmission
    ok(one(srv, ftp.OPEN_FILE_RO, seq=30, session=4, data=b"notes.txt"))
    out = srv.handle(req(ftp.BURST_READ_FILE, seq=31, session=4, size=80), 255, 190, "udp")
    assert [hdr(p)[0] for p in out] == [32, 33] and out[1][3] == ftp.NAK
    assert ok(one(srv, ftp.TERMINATE_SESSION, seq=32, session=4))[5] == ftp.TERMINATE_SESSION


def test_a_fifo_in_the_root_does_not_hang_the_server(srv, root):
    os.mkfifo(root / "pipe")
    assert nak_of(one(srv, ftp.CREATE_FILE, session=1, data=b"pipe")) == (ftp.ERR_FAIL_ERRNO, errno.ENXIO)
    ok(one(srv, ftp.OPEN_FILE_RO, session=2, data=b"pipe"))
    assert nak_of(one(srv, ftp.READ_FILE, session=2, size=10)) == (ftp.ERR_FAIL_ERRNO, errno.ESPIPE)
    assert b"pipe" not in b"".join(listing(srv, b"/")[0])                   # ArduPilot lists files and dirs only


def test_a_root_that_cannot_be_made_leaves_the_virtual_files(tmp_path, clock):
    (tmp_path / "file").write_bytes(b"")
    srv = ftp.FtpServer({"@PARAM/param.pck": lambda d: PARAMS}, root=tmp_path / "file" / "vehicles" / "0",
                        clock=clock)
    assert nak_of(one(srv, ftp.LIST_DIRECTORY, data=b"/")) == (ftp.ERR_FILE_NOT_FOUND,)
    ok(one(srv, ftp.OPEN_FILE_RO, data=b"@PARAM/param.pck"))


@settings(max_examples=150, deadline=None)
@given(requests=st.lists(st.tuples(st.integers(0, 20) | st.integers(0, 255), st.integers(0, 6), st.integers(0, 255),
                                   st.integers(0, 2**32 - 1) | st.integers(0, 2000),
                                   st.binary(max_size=239) | st.lists(st.sampled_from(
                                       [b"logs", b"..", b"/", b"@MAV_LOG", b"@PARAM", b"@SYS", b"uarts.txt", b"param.pck", b"x", b"\0"]),
                                       max_size=6).map(b"/".join)),
                         min_size=1, max_size=12))
def test_any_request_sequence_is_answered_without_raising(requests):
    import tempfile
    with tempfile.TemporaryDirectory() as t:
        root = os.path.join(t, "vehicles", "0")
        srv = ftp.FtpServer({"@PARAM/param.pck": lambda d: PARAMS}, root=root, clock=Clock())
        for seq, (opcode, session, size, offset, data) in enumerate(requests):
            payload = struct.pack("<HBBBBBBI", seq, session, opcode, size, 0, 0, 0, offset) + data
            out = srv.handle(payload[:251], 255, 190, "udp")
            assert opcode in (ftp.ACK, ftp.NAK) or 1 <= len(out) <= srv.BURST_PACKETS
            assert all(len(r) == 251 and r[3] in (ftp.ACK, ftp.NAK) and r[5] == opcode for r in out)
        srv.close()
        assert os.listdir(os.path.join(t, "vehicles", ".0.partial")) == []
