"""The MAVFTP payload (FILE_TRANSFER_PROTOCOL.payload, 251 bytes) as ArduPilot's GCS_FTP reads
and writes it: seq u16, session u8, opcode u8, size u8, req_opcode u8, burst_complete u8,
padding u8, offset u32 (all little-endian), data[239].

A reply carries the request's seq + 1 (wrapping at 65536), its session and its opcode as
req_opcode; the unused data bytes are zero. A NAK's data is one error byte, two for
FailErrno (the errno follows).
"""
from __future__ import annotations

import errno as _errno
import struct
from dataclasses import dataclass

HEADER = struct.Struct("<HBBBBBBI")
DATA_MAX = 239
PAYLOAD_LEN = 251
NAME_MAX = DATA_MAX - 1          # GCS_FTP zeroes the last data byte: a path has 238 bytes at most

# opcodes (MAV_FTP_OPCODE)
NONE, TERMINATE_SESSION, RESET_SESSIONS, LIST_DIRECTORY, OPEN_FILE_RO, READ_FILE = 0, 1, 2, 3, 4, 5
CREATE_FILE, WRITE_FILE, REMOVE_FILE, CREATE_DIRECTORY, REMOVE_DIRECTORY = 6, 7, 8, 9, 10
OPEN_FILE_WO, TRUNCATE_FILE, RENAME, CALC_FILE_CRC32, BURST_READ_FILE = 11, 12, 13, 14, 15
ACK, NAK = 128, 129

# errors (MAV_FTP_ERR), the first data byte of a NAK
ERR_FAIL, ERR_FAIL_ERRNO, ERR_INVALID_DATA_SIZE, ERR_INVALID_SESSION = 1, 2, 3, 4
ERR_NO_SESSIONS, ERR_EOF, ERR_UNKNOWN_COMMAND, ERR_FILE_EXISTS = 5, 6, 7, 8
ERR_FILE_PROTECTED, ERR_FILE_NOT_FOUND = 9, 10
ENOENT = _errno.ENOENT


@dataclass
class Request:
    """One decoded request; `data` is always the full 239 data bytes (zero padded)."""
    seq: int
    session: int
    opcode: int
    size: int
    offset: int
    data: bytes

    @classmethod
    def parse(cls, payload: bytes | list[int]) -> Request | None:
        """None for a payload too short to hold the header (no seq to answer with)."""
        raw = bytes(payload)
        if len(raw) < HEADER.size:
            return None
        seq, session, opcode, size, _req, _burst, _pad, offset = HEADER.unpack_from(raw)
        data = raw[HEADER.size:PAYLOAD_LEN].ljust(DATA_MAX, b"\0")
        return cls(seq, session, opcode, size, offset, data)

    def name(self) -> bytes | None:
        """The path a request names, as GCS_FTP's check_name_len accepts it: `size` is the
        name's length, or its length + 1 when a NUL ends it; the last data byte is dropped.
        None when the size does not fit the name (InvalidDataSize)."""
        n = _strnlen(self.data, DATA_MAX)
        if self.size == 0 or not (n == self.size or (self.size - n == 1 and self.data[-1] == 0)):
            return None
        return self.data[:NAME_MAX].split(b"\0", 1)[0]

    def two_names(self) -> tuple[bytes, bytes] | None:
        """Rename's "old\\0new": size is len(old) + len(new) + 1 (or + 2 with a closing NUL)."""
        len1 = _strnlen(self.data, DATA_MAX - 2)
        second = self.data[len1 + 1:]
        len2 = _strnlen(second, DATA_MAX - (len1 + 1))
        closing_nul = self.size - (len1 + len2) == 2 and self.data[-1] == 0
        if self.data[len1] != 0 or self.size == 0 or (len1 + len2 + 1 != self.size and not closing_nul):
            return None
        return self.data[:len1], self.data[:NAME_MAX][len1 + 1:].split(b"\0", 1)[0]


def _strnlen(b: bytes, n: int) -> int:
    i = b.find(b"\0", 0, n)
    return n if i < 0 else i


def reply(req: Request, opcode: int, data: bytes = b"", offset: int = 0, seq_step: int = 1,
          burst_complete: bool = False) -> bytes:
    """A reply payload (251 bytes) to `req`: seq = req.seq + seq_step (a burst's k-th packet
    steps k + 1)."""
    head = HEADER.pack((req.seq + seq_step) & 0xFFFF, req.session, opcode, len(data), req.opcode,
                       1 if burst_complete else 0, 0, offset & 0xFFFFFFFF)
    return (head + data).ljust(PAYLOAD_LEN, b"\0")


def ack(req: Request, data: bytes = b"", offset: int = 0) -> bytes:
    return reply(req, ACK, data, offset)


def nak(req: Request, error: int, errno: int | None = None, offset: int = 0, seq_step: int = 1,
        burst_complete: bool = False) -> bytes:
    data = bytes([error]) if errno is None else bytes([error, errno & 0xFF])
    return reply(req, NAK, data, offset, seq_step, burst_complete)


def error_data(err: OSError) -> tuple[int, int | None]:
    """GCS_FTP::error for a failed file call: ENOENT -> FileNotFound, EEXIST -> FileExists,
    any other errno -> FailErrno with that errno."""
    if err.errno == _errno.ENOENT:
        return ERR_FILE_NOT_FOUND, None
    if err.errno == _errno.EEXIST:
        return ERR_FILE_EXISTS, None
    return ERR_FAIL_ERRNO, err.errno or _errno.EIO


def os_nak(req: Request, err: OSError, offset: int = 0, seq_step: int = 1, burst_complete: bool = False) -> bytes:
    error, errno = error_data(err)
    return nak(req, error, errno, offset, seq_step, burst_complete)
