"""MAVFTP (FILE_TRANSFER_PROTOCOL) answers as ArduPilot's GCS_FTP gives them (pure: bytes in,
bytes out), for a vehicle that has no files to serve.

Clients (MAVProxy, QGroundControl, MAVSDK) first try to download the parameters as
"@PARAM/param.pck" over MAVFTP and fall back to PARAM_REQUEST_LIST when the open is refused.
An unanswered request makes them wait for their timeout (MAVProxy: seconds per retry), so every
request is answered at once: opening, listing or removing anything is NAKed with FailErrno and
errno ENOENT (the bytes ArduPilot sends for a file that is not there); session commands on no
open session with InvalidSession; TerminateSession and ResetSessions are ACKed; an unknown
opcode gets UnknownCommand and a bad size InvalidDataSize.

Payload layout (MAVLink FTP): seq u16, session u8, opcode u8, size u8, req_opcode u8,
burst_complete u8, padding u8, offset u32, data[239]. The reply's seq is the request's + 1.
"""
from __future__ import annotations

import struct

HEADER = struct.Struct("<HBBBBBBI")
DATA_MAX = 239
PAYLOAD_LEN = 251

# opcodes
TERMINATE_SESSION, RESET_SESSIONS, LIST_DIRECTORY, OPEN_FILE_RO, READ_FILE = 1, 2, 3, 4, 5
CREATE_FILE, WRITE_FILE, REMOVE_FILE, CREATE_DIRECTORY, REMOVE_DIRECTORY = 6, 7, 8, 9, 10
OPEN_FILE_WO, TRUNCATE_FILE, RENAME, CALC_FILE_CRC32, BURST_READ_FILE = 11, 12, 13, 14, 15
ACK, NAK = 128, 129

# errors
ERR_FAIL, ERR_FAIL_ERRNO, ERR_INVALID_DATA_SIZE, ERR_INVALID_SESSION = 1, 2, 3, 4
ERR_NO_SESSIONS, ERR_EOF, ERR_UNKNOWN_COMMAND, ERR_FILE_EXISTS = 5, 6, 7, 8
ERR_FILE_PROTECTED, ERR_FILE_NOT_FOUND = 9, 10
ENOENT = 2

PATH_OPS = {LIST_DIRECTORY, OPEN_FILE_RO, CREATE_FILE, REMOVE_FILE, CREATE_DIRECTORY,
            REMOVE_DIRECTORY, OPEN_FILE_WO, TRUNCATE_FILE, RENAME, CALC_FILE_CRC32}
SESSION_OPS = {READ_FILE, WRITE_FILE, BURST_READ_FILE}


def _pack(seq: int, session: int, opcode: int, req_opcode: int, data: bytes = b"", offset: int = 0) -> bytes:
    out = HEADER.pack((seq + 1) & 0xFFFF, session, opcode, len(data), req_opcode, 0, 0, offset) + data
    return out.ljust(PAYLOAD_LEN, b"\0")


def nak(seq: int, session: int, req_opcode: int, error: int, errno: int | None = None) -> bytes:
    data = bytes([error]) if errno is None else bytes([error, errno])
    return _pack(seq, session, NAK, req_opcode, data)


def answer(payload: bytes | list[int]) -> bytes | None:
    """The reply payload (251 bytes) to one request payload; None for a payload too short to
    hold the header (nothing to answer: no sequence number to echo)."""
    raw = bytes(payload)
    if len(raw) < HEADER.size:
        return None
    seq, session, opcode, size, _req, _burst, _pad, offset = HEADER.unpack_from(raw)
    if opcode in (ACK, NAK):
        return None                                  # a reply looped back to us
    if size > DATA_MAX:
        return nak(seq, session, opcode, ERR_INVALID_DATA_SIZE)
    if opcode in (TERMINATE_SESSION, RESET_SESSIONS):
        return _pack(seq, session, ACK, opcode)
    if opcode in PATH_OPS:
        return nak(seq, session, opcode, ERR_FAIL_ERRNO, ENOENT)
    if opcode in SESSION_OPS:
        return nak(seq, session, opcode, ERR_INVALID_SESSION)
    return nak(seq, session, opcode, ERR_UNKNOWN_COMMAND)
