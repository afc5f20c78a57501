"""A UDP datagram cut into the MAVLink frames a radio link carries, and put back together (pure).

The bridge coalesces telemetry into datagrams as its loop happens to batch it, so datagram
boundaries depend on the machine; the frames inside do not. A faulty link therefore decides per
frame: :func:`cut` splits a datagram into :class:`Unit` s by the headers' lengths (no CRC check:
the receiver checks), each with the stream it belongs to, (sysid, compid, msgid). A datagram
that is not a clean run of MAVLink frames stays one opaque unit (key OPAQUE): the link carries
garbage as it is. :func:`pack` joins units into datagrams of at most MAX_DATAGRAM bytes.
"""
from __future__ import annotations

from dataclasses import dataclass

OPAQUE = (-1, -1, -1)
MAX_DATAGRAM = 1400         # a joined datagram stays within a 1500-byte Ethernet MTU
_SIGNED = 0x01


@dataclass(frozen=True, slots=True)
class Unit:
    """One frame on the link (or a datagram that is not MAVLink): its bytes and its stream."""
    data: bytes
    key: tuple[int, int, int]           # (sysid, compid, msgid), OPAQUE for non-MAVLink bytes


def cut(datagram: bytes) -> list[Unit]:
    """The frames of a datagram, in order; one OPAQUE unit if it is not a clean run of frames."""
    out: list[Unit] = []
    i, n = 0, len(datagram)
    while i < n:
        magic = datagram[i]
        if magic == 0xFD and n - i >= 10:
            total = 12 + datagram[i + 1] + (13 if datagram[i + 2] & _SIGNED else 0)
            key = (datagram[i + 5], datagram[i + 6],
                   datagram[i + 7] | datagram[i + 8] << 8 | datagram[i + 9] << 16)
        elif magic == 0xFE and n - i >= 6:
            total = 8 + datagram[i + 1]
            key = (datagram[i + 3], datagram[i + 4], datagram[i + 5])
        else:
            return [Unit(bytes(datagram), OPAQUE)]
        if i + total > n:
            return [Unit(bytes(datagram), OPAQUE)]
        out.append(Unit(bytes(datagram[i:i + total]), key))
        i += total
    return out


def pack(units: list[Unit], limit: int = MAX_DATAGRAM) -> list[bytes]:
    """Join frames into as few datagrams as fit `limit` bytes each, order kept (a bigger frame,
    and an opaque unit, goes alone)."""
    out: list[bytes] = []
    cur: list[bytes] = []
    size = 0
    for u in units:
        f = u.data
        if cur and (size + len(f) > limit or u.key == OPAQUE):
            out.append(b"".join(cur))
            cur, size = [], 0
        if u.key == OPAQUE:
            out.append(f)
            continue
        cur.append(f)
        size += len(f)
    if cur:
        out.append(b"".join(cur))
    return out
