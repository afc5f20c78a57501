"""MAVLink 2 framing of the vehicle's outgoing messages without pymavlink message objects.

The one home of the vehicle's fast packer. A telemetry builder gives the message's field
values as a tuple in the order of pymavlink's constructor (`fieldnames`); `Framer.frame`
packs them with a precompiled struct.Struct in wire order (`ordered_fieldnames`, arrays
flattened), trims the payload's trailing zero bytes (MAVLink 2; at least one byte stays),
writes the header with the link's sequence number and ids, the X.25 CRC with the message's
CRC_EXTRA and, when the link signs, the 13-byte signature: byte for byte what pymavlink's
`msg.pack(mav)` gives for the same state. The state (seq, srcSystem, srcComponent, signing's
key, link_id and timestamp) stays in the link's pymavlink MAVLink object, so the two paths
can be mixed on one link; like pymavlink's pack, framing does not advance `seq`.

Why: at 1,000 vehicles and ~70 messages per vehicle per second, building a pymavlink message
object per message (its attribute churn, packing and framing in Python) cost more than the rest
of the vehicle's tick. (pymavlink's own CRC is already C when fastcrc is installed, as here.)

The CRC is CRC-16/MCRF4XX (common/mavlink/crc.py: fastcrc's C when installed) over the
header after the magic byte, the payload and CRC_EXTRA.
"""
from __future__ import annotations

import inspect
import struct
from collections.abc import Sequence
from operator import itemgetter

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.crc import x25crc
from common.mavlink.signing import signature

__all__ = ["Framer", "MessageLayout", "layout", "x25crc"]

MAGIC_V2 = 253
IFLAG_SIGNED = 0x01
_MAGIC = bytes((MAGIC_V2,))
_HEADER_REST = struct.Struct("<BBBBBBHB")      # the header after the magic byte (the CRC's start)
_CRC = struct.Struct("<H")


class MessageLayout:
    """Payload layout of one message type, from pymavlink's generated class."""

    __slots__ = ("msgid", "cls", "crc_extra", "struct", "order", "arrays", "crc_byte", "attrs", "defaults", "wire_order")

    def __init__(self, cls) -> None:
        self.msgid = cls.id
        self.cls = cls
        self.crc_extra = cls.crc_extra
        self.crc_byte = bytes((cls.crc_extra,))
        self.struct = cls.unpacker                   # wire order, arrays expanded
        names = list(cls.fieldnames)
        self.order = tuple(names.index(n) for n in cls.ordered_fieldnames)
        # constructor order -> wire order, in C (itemgetter of one index gives no tuple)
        self.wire_order = itemgetter(*self.order) if len(self.order) > 1 else (lambda v: (v[0],))
        types = dict(zip(names, cls.fieldtypes))     # fieldtypes follow constructor order
        # where a message object keeps each field as sent (char[] raw, as pymavlink's pack)
        self.attrs = tuple(f"_{n}_raw" if types[n] == "char" else n for n in names)
        # the constructor's defaults (extension fields): a shorter tuple is padded with them
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        self.defaults = tuple(p.default for p in params)
        # numeric arrays are flattened into the struct; char[] is one 's' item
        self.arrays = any(n > 0 and types[f] != "char" for n, f in zip(cls.array_lengths, cls.ordered_fieldnames))

    def payload(self, values: Sequence) -> bytes:
        """The untrimmed payload of a message with these constructor-order values."""
        if len(values) < len(self.defaults):
            values = (*values, *self.defaults[len(values):])
        if not self.arrays:
            return self.struct.pack(*self.wire_order(values))
        flat: list = []
        cls = self.cls
        for i, n in zip(self.order, cls.array_lengths):
            v = values[i]
            if n > 0 and not isinstance(v, (bytes, str)):
                flat.extend(v[k] for k in range(n))   # as pymavlink: exactly n elements
            else:
                flat.append(v)
        return self.struct.pack(*flat)


_LAYOUTS: dict[int, MessageLayout] = {}


def layout(msgid: int) -> MessageLayout:
    """The (cached) layout of message `msgid` of the ardupilotmega dialect; KeyError if unknown."""
    lay = _LAYOUTS.get(msgid)
    if lay is None:
        lay = _LAYOUTS[msgid] = MessageLayout(mav.mavlink_map[msgid])
    return lay


class Framer:
    """Frames messages for one link whose state lives in `link_mav` (a pymavlink MAVLink)."""

    def __init__(self, link_mav) -> None:
        self.mav = link_mav

    def frame(self, msgid: int, values: Sequence) -> bytes:
        """The MAVLink 2 frame of message `msgid` with constructor-order `values`."""
        lay = _LAYOUTS.get(msgid)
        if lay is None:
            lay = layout(msgid)
        return self.frame_payload(lay, lay.payload(values))

    def frame_payload(self, lay: MessageLayout, payload: bytes) -> bytes:
        m = self.mav
        trimmed = payload.rstrip(b"\0") or payload[:1]      # MAVLink 2: at least one byte stays
        signing = m.signing
        signed = signing.sign_outgoing
        msgid = lay.msgid
        body = _HEADER_REST.pack(len(trimmed), IFLAG_SIGNED if signed else 0, 0, m.seq,
                                 m.srcSystem, m.srcComponent, msgid & 0xFFFF, msgid >> 16) + trimmed
        buf = _MAGIC + body + _CRC.pack(x25crc(body + lay.crc_byte))
        if signed:
            buf += signature(signing.secret_key, buf, signing.link_id, signing.timestamp)
            signing.timestamp += 1
        return buf

    def frame_message(self, msg) -> bytes:
        """A pymavlink message object framed the same way (what `msg.pack(mav)` gives)."""
        msgid = msg.get_msgId()          # not msg.id: BATTERY_STATUS has a field "id"
        lay = _LAYOUTS.get(msgid) or layout(msgid)
        return self.frame_payload(lay, lay.payload([getattr(msg, a) for a in lay.attrs]))
