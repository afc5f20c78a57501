"""What the MAVFTP tests share (no tests here): request payloads as a client packs them, reply
headers decoded, a settable clock, and ArduPilot's crc_crc32 computed bit by bit (an
independent reference for the server's table-driven one)."""
from __future__ import annotations

import struct

from vehicle.link import ftp


def req(opcode, seq=1, session=0, data=b"", size=None, offset=0):
    """A request payload (251 bytes); size defaults to len(data)."""
    size = len(data) if size is None else size
    return (struct.pack("<HBBBBBBI", seq, session, opcode, size, 0, 0, 0, offset) + data).ljust(251, b"\0")


def hdr(reply):
    """(seq, session, opcode, size, req_opcode, burst_complete, padding, offset)"""
    return struct.unpack_from("<HBBBBBBI", reply)


def body(reply) -> bytes:
    return reply[12:12 + reply[4]]


def nak_of(reply) -> tuple[int, ...]:
    """The NAK's error bytes (asserting it is a NAK)."""
    assert reply[3] == ftp.NAK, f"not a NAK: {hdr(reply)} {body(reply)!r}"
    return tuple(body(reply))


class Clock:
    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def crc32_bitwise(data: bytes, crc: int = 0) -> int:
    """crc_crc32 of ArduPilot's AP_Math: reflected polynomial 0xEDB88320, seed 0, no final
    inversion."""
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xEDB88320 if crc & 1 else crc >> 1
    return crc
