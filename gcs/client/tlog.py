"""A client's link recorded as a .tlog (both ways), as MAVProxy writes one.

Each message: an 8-byte big-endian wall-clock stamp in microseconds, then its MAVLink bytes.
"""
from __future__ import annotations

import struct
import time
from typing import Any

_STAMP = struct.Struct(">Q")


class Tlog:
    """Appends every message it is given to a .tlog file; after close it drops them."""

    def __init__(self, path: str) -> None:
        self._f = open(path, "ab")

    def write(self, msg: Any) -> None:
        """Record one message (received, or sent: see on_sent)."""
        self.write_raw(msg.get_msgbuf())

    def write_raw(self, data: bytes) -> None:
        """Record one packet received as bytes (what get_msgbuf() of its message gives)."""
        if self._f is not None:
            usec = int(time.time() * 1.0e6) & ~3
            self._f.write(_STAMP.pack(usec) + data)

    def write_packets(self, packets) -> None:
        """Record the packets of one datagram received (each with its bytes in ``raw``), all
        with the one stamp of their arrival, in one write."""
        if self._f is not None and packets:
            stamp = _STAMP.pack(int(time.time() * 1.0e6) & ~3)
            self._f.write(b"".join(stamp + p.raw for p in packets))

    def on_sent(self, msg: Any, *_a: Any, **_k: Any) -> None:
        """pymavlink's send callback (MAVLink.set_send_callback)."""
        self.write(msg)

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None
