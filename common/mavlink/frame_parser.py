"""MAVLink 1 and 2 frames cut from bytes without decoding payloads (pure: no sockets, no clocks).

:class:`FrameParser` cuts a byte stream (or one UDP datagram) into :class:`Packet` s: the
header fields, the CRC checked (common.mavlink.crc, with the message's CRC_EXTRA) and the
``target_system``/``target_component`` bytes read straight from the payload (MAVLink 2
zero-truncation aware: a truncated field is 0). Garbage runs, bad CRCs, truncated frames,
unknown incompat flags and unknown message ids are counted in ``malformed`` (one per run of
bad bytes) and skipped; it resynchronises on the next magic byte, as pymavlink's robust
parser does. Signatures are kept in ``raw``, never checked here (common.mavlink.signing).

The two versions differ only in the header; one path reads both::

    v1: FE len seq sys comp msgid(1)                      payload crc(2)
    v2: FD len incompat compat seq sys comp msgid(3, LE)  payload crc(2) [signature(13)]

Which messages exist, their CRC_EXTRA and where their target bytes sit come from a table
built from any pymavlink dialect (:func:`message_table`), so this module imports none.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

from common.mavlink.crc import x25crc
from common.mavlink.signing import MAVLINK_IFLAG_SIGNED, SIGNATURE_LEN

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
HEADER_V1 = 6                   # bytes before the payload
HEADER_V2 = 10
MAX_STREAM_BUFFER = 1 << 20     # a stream holding more than this without a frame is dropped


@dataclass(frozen=True, slots=True)
class MsgInfo:
    """What the parser needs of one message id."""
    crc_extra: int
    target_system_ofs: int      # payload byte offset; -1: the message has no target_system
    target_component_ofs: int   # -1: none
    name: str
    crc_byte: bytes             # crc_extra as the one byte the checksum ends with


def field_offsets(cls) -> dict[str, int]:
    """Byte offset of every wire-ordered field of a pymavlink message class."""
    fmt = cls.unpacker.format
    if isinstance(fmt, bytes):
        fmt = fmt.decode()
    tokens, num = [], ""
    for ch in fmt[1:]:
        if ch.isdigit():
            num += ch
        else:
            tokens.append(num + ch)
            num = ""
    out, pos = {}, 0
    for name, tok in zip(cls.ordered_fieldnames, tokens):
        out[name] = pos
        pos += struct.calcsize("<" + tok)
    return out


def message_table(mavlink_map: dict) -> dict[int, MsgInfo]:
    """msgid -> MsgInfo for a pymavlink dialect's ``mavlink_map`` (msgid -> message class)."""
    table = {}
    for msgid, cls in mavlink_map.items():
        ofs = field_offsets(cls)
        table[msgid] = MsgInfo(cls.crc_extra, ofs.get("target_system", -1),
                               ofs.get("target_component", -1), cls.msgname, bytes((cls.crc_extra,)))
    return table


@dataclass(slots=True)
class Packet:
    """One CRC-checked MAVLink packet, not decoded."""
    raw: bytes
    msgid: int
    sysid: int
    compid: int
    seq: int
    target_system: int      # 0 when the message has none (broadcast)
    target_component: int
    v2: bool
    addr: object = None             # UDP sender address (a reply path that is not a peer)
    refused: str | None = None      # why the receiver refused it (then it is not to be used)


class FrameParser:
    """Cut bytes into MAVLink packets; count and skip whatever is not one."""

    __slots__ = ("_skipping", "buf", "malformed", "packets", "table")

    def __init__(self, table: dict[int, MsgInfo]) -> None:
        self.buf = bytearray()
        self.malformed = 0
        self.packets = 0
        self._skipping = False
        self.table = table

    def _bad(self) -> None:
        if not self._skipping:
            self.malformed += 1
            self._skipping = True

    def feed(self, data: bytes, datagram: bool = False) -> list[Packet]:
        """Packets found in `data` (appended to what is pending).

        datagram=True treats `data` as a whole UDP datagram: a partial packet left at
        its end is truncated input (counted), not something to wait for.
        """
        buf = self.buf
        # a whole datagram with nothing pending is cut straight from its bytes (no copy)
        direct = datagram and not buf and type(data) is bytes
        if direct:
            buf = data
        else:
            buf += data
        out: list[Packet] = []
        i, n = 0, len(buf)
        table = self.table
        while i < n:
            magic = buf[i]
            if magic == MAGIC_V2:
                if n - i < HEADER_V2:
                    break
                incompat = buf[i + 2]
                if incompat & ~MAVLINK_IFLAG_SIGNED:
                    self._bad(); i += 1; continue
                plen = buf[i + 1]
                pay0 = i + HEADER_V2
                total = HEADER_V2 + plen + 2 + (SIGNATURE_LEN if incompat else 0)
                msgid = buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
                ids = i + 4                 # seq, sysid, compid, one after another
            elif magic == MAGIC_V1:
                if n - i < HEADER_V1:
                    break
                plen = buf[i + 1]
                pay0 = i + HEADER_V1
                total = HEADER_V1 + plen + 2
                msgid = buf[i + 5]
                ids = i + 2
            else:
                self._bad(); i += 1; continue
            if n - i < total:
                break
            info = table.get(msgid)
            if info is None:
                self._bad(); i += 1; continue
            end_crc = pay0 + plen
            if x25crc(buf[i + 1:end_crc] + info.crc_byte) != (buf[end_crc] | buf[end_crc + 1] << 8):
                self._bad(); i += 1; continue
            ts = buf[pay0 + info.target_system_ofs] if 0 <= info.target_system_ofs < plen else 0
            tc = buf[pay0 + info.target_component_ofs] if 0 <= info.target_component_ofs < plen else 0
            out.append(Packet(bytes(buf[i:i + total]), msgid, buf[ids + 1], buf[ids + 2], buf[ids],
                              ts, tc, magic == MAGIC_V2))
            i += total
            self._skipping = False
        if direct:
            if i < n:
                self._bad()
            self._skipping = False
            self.packets += len(out)
            return out
        del buf[:i]
        if datagram and buf:
            self._bad()
            buf.clear()
        if datagram:
            self._skipping = False
        if len(buf) > MAX_STREAM_BUFFER:
            self._bad()
            buf.clear()
        self.packets += len(out)
        return out
