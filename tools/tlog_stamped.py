"""A tlog's frames decoded as far as their reader needs: the messages it reads decoded, the others as their sim time.

A reader such as tools.scene_feed.SceneFeed (its FED_TYPES) or tools.run_data.load_messages (its
FOLDED) reads the fields of a few messages; every other one counts only through its sim time
(time_boot_ms, or time_usec), and one with neither not at all. :class:`StampedDecoder` decodes the
named messages (pymavlink, as :func:`decode_frames`); a message with a time field becomes a
:class:`Stamped` (its name, sender, time fields and tlog stamp, read straight from the frame after
the checksum pymavlink checks), and one without is left out: the reader makes the same of them for
a fraction of the decoding (a lab run's bridge.tlog is some 20,000 frames, 5,000 of them the
scene's).
"""
from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from common.mavlink.crc import x25crc
from common.mavlink.frame_parser import field_offsets

_TIME_FIELDS = {"time_usec": "<Q", "time_boot_ms": "<I"}


class Stamped:
    """A message read only for its time: what its reader and a merge by tlog stamp ask of it."""

    __slots__ = ("_link", "_name", "_sysid", "_timestamp", "time_boot_ms", "time_usec")

    def __init__(self, name: str, sysid: int, time_usec: int | None, time_boot_ms: int | None,
                 tusec: int) -> None:
        self._name = name
        self._sysid = sysid
        self.time_usec = time_usec              # None: the message has no such field
        self.time_boot_ms = time_boot_ms
        self._timestamp = tusec * 1e-6          # the tlog's stamp, s (as read_tlog's)
        self._link = tusec & 0x3

    def get_type(self) -> str:
        return self._name

    def get_srcSystem(self) -> int:  # noqa: N802 - pymavlink's name
        return self._sysid


@dataclass(frozen=True, slots=True)
class _Timed:
    """Where a message's time fields sit in its (zero-padded) payload."""
    name: str
    crc_extra: int
    size: int                                   # the full payload's bytes
    fields: tuple[tuple[str, int, struct.Struct], ...]    # (name, offset, codec)


def decode_frames(mav, raw: bytes, frames: Iterable[tuple[int, int, int, int]], wanted: frozenset[int] | None,
                  sysids: Iterable[int] | None) -> Iterator[Any]:
    """Decode tlog frames (tools.run_data.tlog_frames' rows of `raw`) with the MAVLink object `mav`,
    those of the `wanted` ids (None: all) and `sysids` (None: all); each message has ``_timestamp``
    (s) and ``_link`` as pymavlink's log reader gives them."""
    systems = None if sysids is None else frozenset(sysids)
    for tusec, msgid, start, end in frames:
        if wanted is not None and msgid not in wanted:
            continue
        if systems is not None and raw[start + (5 if raw[start] == 0xFD else 3)] not in systems:
            continue
        try:
            m = mav.decode(bytearray(raw[start:end]))
        except Exception:  # noqa: BLE001 - pymavlink's reader gives BAD_DATA, which is skipped
            continue
        m._timestamp = tusec * 1e-6
        m._link = tusec & 0x3
        yield m


class StampedDecoder:
    """Turns tlog frames into the messages a reader of the `fed` messages needs (see the module's
    docstring)."""

    def __init__(self, fed: Iterable[str]) -> None:
        from common.mavlink.dialect import towerlink as dialect
        self.mav = dialect.MAVLink(None)
        fed = frozenset(fed)
        self.full: frozenset[int] = frozenset(i for i, c in dialect.mavlink_map.items() if c.msgname in fed)
        self.timed: dict[int, _Timed] = {}
        for i, cls in dialect.mavlink_map.items():
            if i in self.full:
                continue
            ofs = field_offsets(cls)
            fields = tuple((f, ofs[f], struct.Struct(fmt)) for f, fmt in _TIME_FIELDS.items() if f in ofs)
            if fields:
                self.timed[i] = _Timed(cls.msgname, cls.crc_extra, cls.unpacker.size, fields)

    def decode(self, raw: bytes, frames: Iterable[tuple[int, int, int, int]],
               sysids: Iterable[int] | None = None) -> Iterator[Any]:
        """The messages of tlog frames (tools.run_data.tlog_frames' rows of `raw`), from `sysids`
        (None: all), in their order: fed ones decoded as decode_frames decodes them, the others
        with a time field as Stamped, the rest (and what pymavlink would refuse) left out."""
        systems = None if sysids is None else frozenset(sysids)
        full, timed, mav = self.full, self.timed, self.mav
        for row in frames:
            tusec, msgid, start, end = row
            if msgid in full:
                yield from decode_frames(mav, raw, (row,), None, systems)
                continue
            t = timed.get(msgid)
            if t is None:
                continue
            v2 = raw[start] == 0xFD
            sysid = raw[start + (5 if v2 else 3)]
            if systems is not None and sysid not in systems:
                continue
            head = 10 if v2 else 6
            stop = end - (13 if v2 and raw[start + 2] & 1 else 0)     # less the signature
            if x25crc(bytes((t.crc_extra,)), x25crc(raw[start + 1:stop - 2])) != int.from_bytes(raw[stop - 2:stop], "little"):
                continue                                # pymavlink refuses a bad checksum
            payload = raw[start + head:stop - 2].ljust(t.size, b"\0")    # MAVLink 2 trims zeros
            got = {name: codec.unpack_from(payload, ofs)[0] for name, ofs, codec in t.fields}
            yield Stamped(t.name, sysid, got.get("time_usec"), got.get("time_boot_ms"), tusec)

