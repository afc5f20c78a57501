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


def split_frames(data: bytes) -> tuple[list[tuple[bytes, int, int]], bytes]:
    """The whole MAVLink frames at the start of `data` by their headers alone, each as (bytes,
    sysid, compid), and what follows the last (from the first byte that starts no frame, or a
    frame cut short); nothing is decoded or checked."""
    frames, i, n = [], 0, len(data)
    while i < n:
        magic = data[i]
        if magic == 0xFD and i + 10 <= n:
            total = 12 + data[i + 1] + (13 if data[i + 2] & 1 else 0)
            sysid, compid = data[i + 5], data[i + 6]
        elif magic == 0xFE and i + 6 <= n:
            total = 8 + data[i + 1]
            sysid, compid = data[i + 3], data[i + 4]
        else:
            break
        if i + total > n:
            break
        frames.append((data[i:i + total], sysid, compid))
        i += total
    return frames, data[i:]
