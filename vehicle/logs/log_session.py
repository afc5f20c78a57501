"""One open log file: its records are packed here and handed to the writer thread in
chunks (vehicle/logs/writer.py), never written from the step loop.

A chunk goes to the writer once a second of sim time (or when CHUNK_BYTES have gathered),
so a process crash loses at most that last second; `close()` hands over the rest and
asks the writer to fsync the file.
"""
from __future__ import annotations

from pathlib import Path

from vehicle.logs.dataflash import Schema
from vehicle.logs.writer import LogWriter

FLUSH_PERIOD = 1.0          # sim s between hand-overs to the writer
CHUNK_BYTES = 64 * 1024     # hand over earlier when this much has gathered


class LogSession:
    """Records of one .BIN file, buffered and passed to the writer."""

    def __init__(self, path: Path, schema: Schema, writer: LogWriter, t: float) -> None:
        self.path = path
        self.key = str(path)
        self.schema = schema
        self.writer = writer
        self.buf = bytearray()
        self.bytes = 0                    # handed to the writer so far
        self.next_flush = t + FLUSH_PERIOD
        self.armed_seen = False           # LOG_DISARMED 3: discard a log that never saw arming
        self.closed = False

    def add(self, record: bytes) -> None:
        self.buf += record
        if len(self.buf) >= CHUNK_BYTES:
            self.hand_over()

    def write(self, name: str, *values) -> None:
        """Pack one record of message `name` (values as vehicle/logs/dataflash.py says)."""
        self.add(self.schema[name].pack(*values))

    def tick(self, t: float) -> None:
        if t >= self.next_flush:
            self.next_flush = t + FLUSH_PERIOD
            self.hand_over()

    def hand_over(self) -> None:
        if self.buf:
            data = bytes(self.buf)
            self.buf.clear()
            if self.writer.write(self.key, data):
                self.bytes += len(data)

    def close(self) -> None:
        self.hand_over()
        self.writer.close(self.key)
        self.closed = True
