"""MAVFTP (FILE_TRANSFER_PROTOCOL) as ArduPilot's GCS_FTP answers it (pure: bytes in, bytes out).

Clients (MAVProxy, QGroundControl) first try to download the parameters as "@PARAM/param.pck"
over MAVFTP and fall back to PARAM_REQUEST_LIST when the open is refused; an unanswered
request makes them wait for their timeout. FtpServer serves that one virtual file in
ArduPilot's packed format (param_pck, "?withdefaults=1" included) with OpenFileRO, ReadFile,
BurstReadFile and TerminateSession; every other request is answered at once by `answer()`:
opening, listing or removing anything else is NAKed with FailErrno and errno ENOENT (the bytes
ArduPilot sends for a file that is not there); session commands on no open session with
InvalidSession; ResetSessions ACKed; an unknown opcode gets UnknownCommand, a bad size
InvalidDataSize.

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


# ----- @PARAM/param.pck (ArduPilot's AP_Filesystem_Param format) -----------------------------
PCK_MAGIC, PCK_MAGIC_DEFAULTS = 0x671B, 0x671C
# ArduPilot's AP_PARAM type codes and struct formats, by MAV_PARAM_TYPE
_PCK_TYPES = {2: (1, "b"), 1: (1, "b"), 4: (2, "h"), 3: (2, "h"), 6: (3, "i"), 5: (3, "i"), 9: (4, "f")}


def param_pck(entries, with_defaults: bool = False) -> bytes:
    """entries: (name, value, MAV_PARAM_TYPE, default) in index order -> the file's bytes.

    Header <HHH: magic (0x671c with defaults), parameter count, total count; then per
    parameter: a byte of AP type (low nibble) and flags (bit 4: a default follows), a byte of
    (name suffix length - 1) << 4 | length of the prefix shared with the previous name (<= 15),
    the name suffix, the value, and with defaults the default when it differs."""
    out = [struct.pack("<HHH", PCK_MAGIC_DEFAULTS if with_defaults else PCK_MAGIC, len(entries), len(entries))]
    last = b""
    for name, value, mav_type, default in entries:
        code, fmt = _PCK_TYPES.get(mav_type, (4, "f"))
        nb = name.encode("ascii")[:16]
        common = 0
        while common < min(15, len(last), len(nb) - 1) and last[common] == nb[common]:
            common += 1
        suffix = nb[common:]
        flags = 0
        vals = [value]
        if with_defaults and value != default:
            flags, vals = 1, [value, default]
        if fmt != "f":
            vals = [int(round(v)) for v in vals]
        out.append(struct.pack("<BB", code | flags << 4, (len(suffix) - 1) << 4 | common) + suffix
                   + struct.pack("<" + fmt * len(vals), *vals))
        last = nb
    return b"".join(out)


class FtpServer:
    """MAVFTP sessions over read-only virtual files: `files` maps a path to a function giving
    its bytes (read once, at open, as ArduPilot snapshots @PARAM/param.pck). Anything else is
    answered as `answer()` does. `handle(payload)` -> the reply payloads to send, in order."""

    MAX_SESSIONS = 4
    BURST_PACKETS = 64          # data packets per BurstReadFile before burst_complete

    def __init__(self, files) -> None:
        self.files = dict(files)
        self.sessions: dict[int, bytes] = {}

    def handle(self, payload) -> list[bytes]:
        raw = bytes(payload)
        if len(raw) < HEADER.size:
            return []
        seq, session, opcode, size, _req, _burst, _pad, offset = HEADER.unpack_from(raw)
        if opcode in (ACK, NAK) or size > DATA_MAX:
            r = answer(raw)
            return [r] if r is not None else []
        data = raw[HEADER.size:HEADER.size + size]
        if opcode == OPEN_FILE_RO:
            path = data.split(b"\0", 1)[0].decode("ascii", "replace")
            base = path.split("?", 1)[0]
            if base not in self.files:
                return [nak(seq, session, opcode, ERR_FAIL_ERRNO, ENOENT)]
            if session in self.sessions:
                return [nak(seq, session, opcode, ERR_FAIL)]          # ArduPilot: already open
            if len(self.sessions) >= self.MAX_SESSIONS:
                return [nak(seq, session, opcode, ERR_NO_SESSIONS)]
            content = self.files[base]("withdefaults=1" in path)
            self.sessions[session] = content
            return [_pack(seq, session, ACK, opcode, struct.pack("<I", len(content)))]
        if opcode == TERMINATE_SESSION:
            if self.sessions.pop(session, None) is None:
                return [nak(seq, session, opcode, ERR_INVALID_SESSION)]
            return [_pack(seq, session, ACK, opcode)]
        if opcode == RESET_SESSIONS:
            self.sessions.clear()
            return [_pack(seq, session, ACK, opcode)]
        if opcode in (READ_FILE, BURST_READ_FILE):
            content = self.sessions.get(session)
            if content is None:
                return [nak(seq, session, opcode, ERR_INVALID_SESSION)]
            chunk = size if size else DATA_MAX
            if opcode == READ_FILE:
                if offset >= len(content):
                    return [nak(seq, session, opcode, ERR_EOF)]
                return [_pack(seq, session, ACK, opcode, content[offset:offset + chunk], offset)]
            out = []
            for i in range(self.BURST_PACKETS):
                at = offset + i * chunk
                part = content[at:at + chunk]
                if not part:
                    out.append(_pack(seq, session, NAK, opcode, bytes([ERR_EOF]), at))
                    break
                r = bytearray(_pack(seq, session, ACK, opcode, part, at))
                r[6] = 1 if i == self.BURST_PACKETS - 1 else 0        # burst_complete
                out.append(bytes(r))
                if len(part) < chunk:
                    out.append(_pack(seq, session, NAK, opcode, bytes([ERR_EOF]), at + len(part)))
                    break
            return out
        r = answer(raw)
        return [r] if r is not None else []
