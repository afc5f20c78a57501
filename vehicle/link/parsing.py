"""Received bytes -> pymavlink messages, with what is wrong counted (pure: no sockets).

pymavlink's MAVLink 2 parser in robust mode: one parser per stream channel (a TCP client),
kept across its chunks, and a fresh parse of every UDP datagram (a datagram that ends inside
a frame counts as truncated). Counted in the `stats` given: garbage bytes (bad prefix, or an
input the parser choked on), bad CRC, bad length, truncated frames, unknown message ids.
"""
from __future__ import annotations

import weakref
from collections import Counter

from pymavlink.dialects.v20 import ardupilotmega as mav


class NullFile:
    """pymavlink's MAVLink object needs a file; we pack ourselves, so nothing is written."""
    def write(self, b):
        pass


def new_parser():
    """A robust ardupilotmega MAVLink parser."""
    p = mav.MAVLink(NullFile(), srcSystem=0, srcComponent=0)
    p.robust_parsing = True
    return p


def rejected(m, stats: Counter) -> bool:
    """True (and counted) when `m` is no message of the dialect: bad data or an unknown id."""
    if isinstance(m, mav.MAVLink_bad_data):
        reason = str(getattr(m, "reason", ""))
        if "CRC" in reason:
            stats["bad_crc"] += 1
        elif "prefix" in reason:
            stats["garbage"] += 1
        elif "length" in reason or "Bad message" in reason:
            stats["bad_length"] += 1
        else:
            stats["bad_data"] += 1
        return True
    if isinstance(m, mav.MAVLink_unknown):
        stats["unknown_id"] += 1
        return True
    return False


class ChunkParser:
    """Parses the chunks one link receives; `channel.stream` tells a TCP client's channel
    (its parser lives as long as the channel) from a datagram's."""

    def __init__(self, stats: Counter) -> None:
        self.stats = stats
        self.datagrams = new_parser()
        self.streams: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    def parse(self, data: bytes, channel) -> list:
        """The messages (bad data included, see `rejected`) in one received chunk."""
        if channel.stream:
            parser = self.streams.get(channel)
            if parser is None:
                parser = self.streams[channel] = new_parser()
        else:
            parser = self.datagrams
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:            # never let a malformed input escape
            msgs = []
            self.stats["garbage"] += 1
            parser.buf = bytearray()
            parser.buf_index = 0
        if not channel.stream and parser.buf_len() > 0:
            self.stats["truncated"] += 1
            parser.buf = bytearray()
            parser.buf_index = 0
            parser.expected_length = mav.HEADER_LEN_V1 + 2
        return msgs
