"""pymavlink messages to and from bytes without pymavlink's per-message overhead (pure).

pymavlink's ``MAVLink.decode`` and ``MAVLink_message.pack`` do, for every message, work that
depends only on the message's type (field order, array lengths, which fields are strings) and
build helper objects (a header object, a CRC object) on the way. :class:`MessageCodec` works
that out once per type from a dialect's ``mavlink_map`` and gives the same results:

* :meth:`MessageCodec.decode` returns the message pymavlink's decoder (without a signing key)
  returns for one whole frame: the same fields, header, CRC, buffer and payload; a frame off
  the common path (bad length or CRC, unknown id) goes to pymavlink's decoder itself, so it
  is refused (or read) exactly as pymavlink does;
* :meth:`MessageCodec.pack` returns the bytes ``msg.pack(mav)`` returns for an encoder with
  that seq, sysid and compid and no signing (MAVLink 2, trailing zeros trimmed; or MAVLink 1).
  Signing stays pymavlink's (common.mavlink.signing): this packs unsigned frames only.

tests/test_message_codec.py checks both against pymavlink for every message of the dialect.
"""
from __future__ import annotations

import struct
from operator import attrgetter
from typing import Any

from common.mavlink.crc import x25crc

_V2 = struct.Struct("<BBBBBBBHB")
_V1 = struct.Struct("<BBBBBB")
_CRC = struct.Struct("<H")
MAGIC_V1, MAGIC_V2 = 0xFE, 0xFD
SIGNATURE_LEN = 13


class _Type:
    """What decode and pack need of one message class, worked out once."""

    __slots__ = ("cls", "crc_extra", "crc_byte", "unpacker", "size", "order", "arrays", "strings",
                 "values", "counts", "msgid", "names", "base")

    def __init__(self, cls) -> None:
        self.cls = cls
        self.msgid = cls.id
        self.crc_extra = cls.crc_extra
        self.crc_byte = bytes((cls.crc_extra,))
        self.unpacker = cls.unpacker
        self.size = cls.unpacker.size
        n = len(cls.fieldnames)
        types = dict(zip(cls.fieldnames, cls.fieldtypes))
        lengths = list(cls.lengths)
        if sum(lengths) == len(lengths):        # no arrays: argument i is item orders[i]
            self.order = tuple(cls.orders[:n])
            self.arrays = None
        else:                                   # (first item, count) of argument i
            self.order = None
            self.arrays = tuple((sum(lengths[:o]), lengths[o]) for o in cls.orders[:n])
        self.strings = tuple(i for i, f in enumerate(cls.fieldnames) if types[f] == "char")
        # without strings, the generated __init__ only stores its arguments after the base
        # class's attributes: a decoded message is built from these directly
        self.names = tuple(cls.fieldnames)
        self.base = None if self.strings else {
            "_fieldnames": cls.fieldnames, "_type": cls.msgname, "_signed": False, "_link_id": None,
            "_instances": None, "_instance_field": cls.instance_field, "_instance_offset": cls.instance_offset}
        # what pack() hands the unpacker, in wire order: the attributes (a string's raw bytes),
        # and how many items each array gives (None: no arrays, every attribute is one item)
        names = [f"_{f}_raw" if types[f] == "char" else f for f in cls.ordered_fieldnames]
        get = attrgetter(*names)
        self.values = get if len(names) > 1 else (lambda msg: (get(msg),))
        counts = tuple(0 if types[f] == "char" else alen for f, alen in zip(cls.ordered_fieldnames, cls.array_lengths))
        self.counts = counts if any(counts) else None


class MessageCodec:
    """Decode and pack one dialect's messages as pymavlink does (see the module docstring)."""

    def __init__(self, module: Any) -> None:
        """`module`: a generated pymavlink dialect (its ``mavlink_map`` and ``MAVLink_header``)."""
        self._header = module.MAVLink_header
        self._pymavlink = module.MAVLink(None)
        self._map = module.mavlink_map
        self._types: dict[int, _Type] = {}          # worked out on first use (a process meets few)
        self._by_class: dict[type, _Type] = {}

    def _learn(self, cls) -> _Type | None:
        if cls is None:
            return None
        t = self._types[cls.id] = self._by_class[cls] = _Type(cls)
        return t

    def decode(self, raw) -> Any:
        """The message in one whole frame `raw` (bytes-like), as pymavlink's decoder gives it
        (raising what it raises)."""
        try:
            return self._decode(raw)
        except (ValueError, IndexError):
            return self._pymavlink.decode(bytearray(raw))

    def _decode(self, raw) -> Any:
        if raw[0] == MAGIC_V1:
            hl, incompat, compat = 6, 0, 0
            mlen, seq, sysid, compid, msgid = raw[1], raw[2], raw[3], raw[4], raw[5]
        elif raw[0] == MAGIC_V2 and len(raw) >= 10:
            hl, incompat, compat = 10, raw[2], raw[3]
            mlen, seq, sysid, compid = raw[1], raw[4], raw[5], raw[6]
            msgid = raw[7] | raw[8] << 8 | raw[9] << 16
        else:
            raise ValueError("not a MAVLink frame")
        end = len(raw) - 2 - (SIGNATURE_LEN if incompat & 1 else 0)
        if mlen != end - hl:
            raise ValueError("bad length")
        t = self._types.get(msgid) or self._learn(self._map.get(msgid))
        if t is None:
            raise ValueError(f"unknown message id {msgid}")
        crc = raw[end] | raw[end + 1] << 8
        if x25crc(bytes(raw[1:end]) + t.crc_byte) != crc:
            raise ValueError("bad CRC")
        payload = bytes(raw[hl:end])
        if mlen < t.size:
            payload += bytes(t.size - mlen)
        items = t.unpacker.unpack(payload if mlen == t.size else payload[:t.size])
        if t.order is not None:
            args = [items[i] for i in t.order]
        else:
            args = [items[tip] if n == 1 or isinstance(items[tip], bytes) else list(items[tip:tip + n])
                    for tip, n in t.arrays]
        buf = bytearray(raw)
        header = self._header(msgid, incompat, compat, mlen, seq, sysid, compid)
        if t.base is not None:
            m = object.__new__(t.cls)
            d = m.__dict__
            d.update(t.base)
            d.update(zip(t.names, args))
        else:
            for i in t.strings:
                args[i] = args[i].rstrip(b"\x00")
            m = t.cls(*args)
            d = m.__dict__
        d["_msgbuf"] = buf
        d["_payload"] = buf[6:end]        # sic: pymavlink's offset, whatever the version
        d["_crc"] = crc
        d["_header"] = header
        return m

    def pack(self, msg, seq: int, sysid: int, compid: int, v2: bool = True) -> bytes:
        """The unsigned frame pymavlink packs for `msg` from an encoder at (seq, sysid, compid)."""
        t = self._by_class.get(type(msg)) or self._learn(type(msg))
        vals = t.values(msg)
        if t.counts is not None:
            flat: list = []
            for v, n in zip(vals, t.counts):
                if n:
                    flat.extend(v[:n])
                else:
                    flat.append(v)
            vals = flat
        payload = t.unpacker.pack(*vals)
        if v2:
            n = len(payload)
            while n > 1 and payload[n - 1] == 0:
                n -= 1
            head = _V2.pack(MAGIC_V2, n, 0, 0, seq, sysid, compid, t.msgid & 0xFFFF, t.msgid >> 16)
            body = head + payload[:n]
        else:
            body = _V1.pack(MAGIC_V1, len(payload), seq, sysid, compid, t.msgid) + payload
        return body + _CRC.pack(x25crc(body[1:] + t.crc_byte))
