"""What a test's world said, recorded as a .tlog: the vehicles push their streams to one UDP
socket of the test's (an extra ``udpout`` endpoint on every vehicle), and a thread writes each
MAVLink frame with its wall-clock stamp (8-byte big-endian microseconds, as MAVProxy's tlog).

The socket is bound to a port the OS picks, so it races nobody. With a listener (a world in
another process: the fixture's truth comes from here) every frame is also decoded and handed
to it; without one frames are only cut apart, which costs little beside the world's thread.
"""
from __future__ import annotations

import select
import socket
import struct
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

_STAMP = struct.Struct(">Q")
_V1, _V2 = 0xFE, 0xFD
_SIGNED = 0x01
BATCH_S = 0.02          # wall s between two drains of the socket (its buffer holds far more)


def split_frames(data: bytes) -> list[bytes]:
    """The MAVLink 1/2 frames of one datagram, in order; bytes that start no frame are skipped
    and a frame cut short by the datagram's end is dropped (the vehicles send whole frames)."""
    out, i, n = [], 0, len(data)
    while i + 1 < n:
        stx = data[i]
        if stx == _V2 and i + 3 <= n:
            size = 12 + data[i + 1] + (13 if data[i + 2] & _SIGNED else 0)
        elif stx == _V1:
            size = 8 + data[i + 1]
        else:
            i += 1
            continue
        if i + size > n:
            break
        out.append(data[i:i + size])
        i += size
    return out


class Recorder:
    """A UDP sink on 127.0.0.1 (``port``) writing every frame it gets to `tlog`; with
    `on_message`, also decodes each frame (pymavlink, ardupilotmega) and calls it."""

    def __init__(self, tlog: Path, on_message: Callable[[Any], None] | None = None) -> None:
        self.path = Path(tlog)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
        self.sock.setblocking(False)
        self.port: int = self.sock.getsockname()[1]
        self.on_message = on_message
        self._parser = None
        if on_message is not None:
            from pymavlink.dialects.v20 import ardupilotmega as mav
            self._parser = mav.MAVLink(None)
            self._parser.robust_parsing = True
        self._f = open(self.path, "wb")
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.frames = 0
        self._thread = threading.Thread(target=self._run, name="towerlink-recorder", daemon=True)

    @property
    def spec(self) -> str:
        """The endpoint a vehicle pushes to (towerlink sitl --endpoint / --out spelling)."""
        return f"udpout:127.0.0.1:{self.port}"

    def start(self) -> "Recorder":
        self._thread.start()
        return self

    def _run(self) -> None:
        # drained every BATCH_S, not woken per datagram: an in-process world sends one every
        # autopilot tick (thousands a wall second at max speed), and each wake-up would take
        # the interpreter lock from the world's thread
        while not self._stop.is_set():
            ready, _, _ = select.select([self.sock], [], [], 0.1)
            if ready:
                self.drain()
            self._stop.wait(BATCH_S)

    def drain(self) -> int:
        """Record (and hand to the listener) every datagram waiting now; how many. Safe from
        any thread: a reader of the listener's truth calls it to be up to date."""
        n = 0
        with self._lock:
            while self._f is not None:
                try:
                    data = self.sock.recv(65535)
                except OSError:          # nothing waiting (BlockingIOError), or closed
                    break
                n += 1
                self._write(data)
        return n

    def _write(self, data: bytes) -> None:
        stamp = _STAMP.pack(int(time.time() * 1e6))
        frames = split_frames(data)
        self._f.write(b"".join(stamp + f for f in frames))
        self.frames += len(frames)
        if self._parser is not None:
            for m in self._parser.parse_buffer(data) or []:
                self.on_message(m)

    def flush(self) -> Path:
        """Everything received so far is in the file; returns its path."""
        with self._lock:
            if self._f is not None:
                self._f.flush()
        return self.path

    def stop(self) -> None:
        """Stop receiving and close the file and the socket (a second call does nothing)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(2.0)
        with self._lock:
            if self._f is not None:
                self._f.close()
                self._f = None
        self.sock.close()
