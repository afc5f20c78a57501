"""MAVFTP (FILE_TRANSFER_PROTOCOL) as ArduPilot's GCS_FTP serves it (pure: bytes in, bytes out).

Followed: ArduPilot master's GCS_FTP class (libraries/GCS_MAVLink/GCS_FTP.cpp, GCS_FTP.h) on
SITL's AP_Filesystem (posix backend, "@" virtual directories, the @MAV_LOG alias):

- sessions (vehicle/files/ftp_sessions.py): 5 slots keyed by the requester and the session
  byte it chose; NoSessionsAvailable while all are busy (< 3 s); idle ones closed after 20 s;
  ResetSessions closes the requester's and is always ACKed;
- every opcode: None, TerminateSession, ResetSessions, ListDirectory (entries "F<name>\\t<size>"
  / "D<name>", NUL-terminated, as many as fit in 239 bytes, offset = entries to skip, NAK
  EndOfFile past the end), OpenFileRO (ACK: the size, u32), ReadFile, BurstReadFile
  (BURST_PACKETS ACKs back to back, burst_complete on the last; NAK EndOfFile at the end of
  the file), CreateFile, OpenFileWO, WriteFile, CreateDirectory, RemoveFile /
  RemoveDirectory (both rmdir-then-unlink), Rename ("old\\0new"), CalcFileCRC32 (ArduPilot's
  crc_crc32, seed 0); one file open per session (a second open: NAK Fail; an open read file
  idle 3 s is closed by the next OpenFileRO);
- errors as GCS_FTP::error maps them: ENOENT -> FileNotFound, EEXIST -> FileExists, other
  errno -> FailErrno + errno; bad name sizes InvalidDataSize; no open file FileNotFound;
  size > 239 InvalidDataSize; Ack/Nack received are not answered; InvalidSession is never
  sent (4.5's single global session sent it to a second session while a file was open);
- a retransmitted request (same requester, session, opcode and seq as the last reply answered)
  gets that reply again without being re-executed.

Where this differs, on purpose: TruncateFile truncates the file to `offset` bytes, as the
MAVLink FTP specification defines it (ArduPilot NAKs it); an unknown opcode gets
UnknownCommand (newest ArduPilot; older NAK Fail), which clients use to fall back from
opcodes of their own (MAVProxy's ListDirectoryWithTime); list entries are separated by one
NUL (ArduPilot 4.5 left a second one); uploads are staged and put in place whole when the
session closes (vehicle/files/staged.py) where ArduPilot writes in place; the duplicate check
also compares the opcode; paths never leave the vehicle's root (vehicle/files/jail.py); bursts
are BURST_PACKETS long (ArduPilot: 2000 packets paced by its link's free buffer; ours go out
at once); opening @PARAM/param.pck sends no banner.

The file tree (vehicle/files/tree.py): the vehicle's root directory plus virtual files
(`files`: "@PARAM/param.pck" -> content(with_defaults)) and @SYS (vehicle/files/sys_dir.py);
without a root only those. The root's listing ends with the "@" directories ArduPilot
appends to it ("@SYS", "@MAV_LOG").
"""
from __future__ import annotations

import os
import struct
import time
from collections.abc import Callable, Hashable, Mapping

from vehicle.files.ftp_sessions import SLOTS, TAKEOVER_S, Session, SessionTable
from vehicle.files.ftp_wire import (  # noqa: F401
    ACK,
    BURST_READ_FILE,
    CALC_FILE_CRC32,
    CREATE_DIRECTORY,
    CREATE_FILE,
    DATA_MAX,
    ENOENT,
    ERR_EOF,
    ERR_FAIL,
    ERR_FAIL_ERRNO,
    ERR_FILE_EXISTS,
    ERR_FILE_NOT_FOUND,
    ERR_FILE_PROTECTED,
    ERR_INVALID_DATA_SIZE,
    ERR_INVALID_SESSION,
    ERR_NO_SESSIONS,
    ERR_UNKNOWN_COMMAND,
    HEADER,
    LIST_DIRECTORY,
    NAK,
    NONE,
    OPEN_FILE_RO,
    OPEN_FILE_WO,
    PAYLOAD_LEN,
    READ_FILE,
    REMOVE_DIRECTORY,
    REMOVE_FILE,
    RENAME,
    RESET_SESSIONS,
    TERMINATE_SESSION,
    TRUNCATE_FILE,
    WRITE_FILE,
    Request,
    ack,
    nak,
    os_nak,
    reply,
)
from vehicle.files.param_pck import PCK_MAGIC, PCK_MAGIC_DEFAULTS, param_pck  # noqa: F401
from vehicle.files.sys_dir import SysDir
from vehicle.files.tree import VehicleFiles


class FtpServer:
    """One vehicle's MAVFTP server. `handle(payload, sysid, compid, channel)` -> the reply
    payloads to send back to that requester, in order; `close()` closes every session."""

    MAX_SESSIONS = SLOTS
    BURST_PACKETS = 64          # data packets per BurstReadFile before burst_complete

    def __init__(self, files: Mapping[str, Callable[[bool], bytes]], root: str | os.PathLike | None = None,
                 clock: Callable[[], float] = time.monotonic, sys_dir: SysDir | None = None) -> None:
        """files: virtual read-only files, path -> content(with_defaults), read at open (as
        ArduPilot snapshots @PARAM/param.pck); root: the vehicle's directory (created if
        missing), None for none; clock(): seconds, for the session timeouts; sys_dir: @SYS
        (one without ports when not given)."""
        self.files = dict(files)
        self.tree = VehicleFiles(root, self.files, sys_dir)
        self.sessions = SessionTable()
        self.clock = clock
        self._last: tuple[tuple, bytes] | None = None    # (key, reply) of the last answer
        self._ops = {NONE: self._none, TERMINATE_SESSION: self._terminate, LIST_DIRECTORY: self._list,
                     OPEN_FILE_RO: self._open_read, READ_FILE: self._read, BURST_READ_FILE: self._burst,
                     CREATE_FILE: self._open_write, OPEN_FILE_WO: self._open_write, WRITE_FILE: self._write,
                     CREATE_DIRECTORY: self._path_op, REMOVE_FILE: self._path_op,
                     REMOVE_DIRECTORY: self._path_op, TRUNCATE_FILE: self._path_op,
                     CALC_FILE_CRC32: self._crc32, RENAME: self._rename}

    def handle(self, payload, sysid: int = 0, compid: int = 0, channel: Hashable = None) -> list[bytes]:
        """The replies to one request payload from (sysid, compid) on `channel` (anything
        hashable naming the link it came by): none to a payload too short for a header or to
        an Ack/Nack, several to a burst."""
        req = Request.parse(payload)
        if req is None or req.opcode in (ACK, NAK):
            return []                                     # nothing to answer / a reply looped back
        now = self.clock()
        self.sessions.expire(now)
        peer = (sysid, compid, channel)
        if req.opcode == RESET_SESSIONS:
            self.sessions.reset(peer)
            return self._answered(peer, req, [ack(req)])
        session = self.sessions.find(peer, req.session, now)
        if session is None:
            self._last = None                             # never replayed
            return [nak(req, ERR_NO_SESSIONS)]
        key = (sysid, compid, req.session, req.opcode, (req.seq + 1) & 0xFFFF)
        if self._last is not None and self._last[0] == key:
            session.last_send = now
            return [self._last[1]]
        if req.size > DATA_MAX:
            out = [nak(req, ERR_INVALID_DATA_SIZE)]
        else:
            out = self._ops.get(req.opcode, self._unknown)(session, req, now)
        session.last_send = None if req.opcode == TERMINATE_SESSION else now
        return self._answered(peer, req, out)

    def close(self) -> None:
        """Close every session (uploads put in place)."""
        self.sessions.close_all()

    def _answered(self, peer, req: Request, out: list[bytes]) -> list[bytes]:
        last = out[-1]
        self._last = ((peer[0], peer[1], req.session, req.opcode, HEADER.unpack_from(last)[0]), last)
        return out

    # ----- opcodes: (session, request, now) -> replies ------------------------------------------
    def _none(self, s: Session, req: Request, now: float) -> list[bytes]:
        return [ack(req)]

    def _unknown(self, s: Session, req: Request, now: float) -> list[bytes]:
        return [nak(req, ERR_UNKNOWN_COMMAND)]

    def _terminate(self, s: Session, req: Request, now: float) -> list[bytes]:
        try:
            s.close()
        except OSError as e:
            return [os_nak(req, e)]
        return [ack(req)]

    def _list(self, s: Session, req: Request, now: float) -> list[bytes]:
        path = req.name()
        if path is None:
            return [nak(req, ERR_INVALID_DATA_SIZE, offset=req.offset)]
        if len(path) > 1 and path.endswith(b"/"):
            path = path[:-1]
        try:
            entries = [e for e in self.tree.listing(path) if len(e) + 1 < DATA_MAX]   # others never fit
        except OSError as e:
            return [os_nak(req, e, offset=req.offset)]
        data = b""
        for e in entries[req.offset:]:
            if len(data) + len(e) + 1 >= DATA_MAX:
                break
            data += e + b"\0"
        if not data:
            return [nak(req, ERR_EOF, offset=req.offset)]
        return [ack(req, data, req.offset)]

    def _open_read(self, s: Session, req: Request, now: float) -> list[bytes]:
        if s.file is not None and s.last_send is not None and now - s.last_send > TAKEOVER_S:
            s.close_quietly()                  # the client gave up on our ACK: open afresh
        if s.file is not None:
            return [nak(req, ERR_FAIL)]
        return self._named(req, lambda path: self._opened(s, self.tree.open_read(path)))

    @staticmethod
    def _opened(s: Session, f) -> bytes:
        """Keep the file in the session; OpenFileRO's ACK data: its size, u32."""
        s.file = f
        return struct.pack("<I", f.size & 0xFFFFFFFF)

    def _named(self, req: Request, act: Callable[..., bytes | None], two: bool = False) -> list[bytes]:
        """The reply to a request naming a path (two, "old\\0new", for Rename): InvalidDataSize
        when the size does not fit the name; else act(*names) -> the ACK's data (None: none),
        and the NAK for the OSError it raises."""
        if two:
            names = req.two_names()
        else:
            name = req.name()
            names = None if name is None else (name,)
        if names is None:
            return [nak(req, ERR_INVALID_DATA_SIZE)]
        try:
            data = act(*names)
        except OSError as e:
            return [os_nak(req, e)]
        return [ack(req, data or b"")]

    def _readable(self, s: Session, req: Request) -> bytes | None:
        """The NAK for a read without a file open for reading, else None."""
        if s.file is None:
            return nak(req, ERR_FILE_NOT_FOUND)
        return nak(req, ERR_FAIL) if s.file.writable else None

    def _read(self, s: Session, req: Request, now: float) -> list[bytes]:
        refused = self._readable(s, req)
        if refused is not None:
            return [refused]
        try:
            data = s.file.read(req.offset, min(DATA_MAX, req.size))
        except OSError as e:
            return [os_nak(req, e)]
        return [ack(req, data, req.offset) if data else nak(req, ERR_EOF)]

    def _burst(self, s: Session, req: Request, now: float) -> list[bytes]:
        refused = self._readable(s, req)
        if refused is not None:
            return [refused]
        chunk, at, out = req.size or DATA_MAX, req.offset, []
        for i in range(self.BURST_PACKETS):
            try:
                data = s.file.read(at, chunk)
            except OSError as e:
                out.append(os_nak(req, e, offset=at, seq_step=i + 1, burst_complete=True))
                break
            if not data:
                out.append(nak(req, ERR_EOF, offset=at, seq_step=i + 1, burst_complete=True))
                break
            out.append(reply(req, ACK, data, at, seq_step=i + 1, burst_complete=i == self.BURST_PACKETS - 1))
            at += len(data)
        return out

    def _open_write(self, s: Session, req: Request, now: float) -> list[bytes]:
        if s.file is not None:
            return [nak(req, ERR_FAIL)]

        def open_write(path: bytes) -> None:
            s.file = self.tree.open_write(path, truncate=req.opcode == CREATE_FILE)
        return self._named(req, open_write)

    def _write(self, s: Session, req: Request, now: float) -> list[bytes]:
        if s.file is None:
            return [nak(req, ERR_FILE_NOT_FOUND)]
        if not s.file.writable:
            return [nak(req, ERR_FAIL)]
        try:
            s.file.write(req.offset, req.data[:req.size])
        except OSError as e:
            return [os_nak(req, e)]
        return [ack(req, offset=req.offset)]

    def _path_op(self, s: Session, req: Request, now: float) -> list[bytes]:
        """CreateDirectory, RemoveFile, RemoveDirectory, TruncateFile: one path, ACK or NAK."""
        t = self.tree
        act = {CREATE_DIRECTORY: t.mkdir, TRUNCATE_FILE: lambda path: t.truncate(path, req.offset)}
        return self._named(req, act.get(req.opcode, t.remove))

    def _rename(self, s: Session, req: Request, now: float) -> list[bytes]:
        return self._named(req, self.tree.rename, two=True)

    def _crc32(self, s: Session, req: Request, now: float) -> list[bytes]:
        return self._named(req, lambda path: struct.pack("<I", self.tree.crc32(path)))
