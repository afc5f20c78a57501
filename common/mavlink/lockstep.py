"""TOWERLINK_LOCKSTEP (43005) on the wire, without the generated dialect (pure: no sockets, no clocks).

The simulated vehicle may not import the generated dialect module (common.mavlink.dialect), so the
world packs and reads this one message here; tests/test_lockstep.py checks these bytes
against common.mavlink.dialect.towerlink (the same CRC_EXTRA, field order and lengths).

The handshake (docs/ARCHITECTURE.md "Lockstep"):

* a participant (bridge, tower) sends JOIN until the first TICK arrives;
* the world, at every lockstep frame (sim time t), sends TICK(t) after everything else it
  sent up to t, to every address a participant joined from, and waits;
* the participant handles everything before the TICK, sends its reactions, then ACK(t)
  on the same path, so the world receives the reactions before the ACK;
* the TICK's ``lag`` says when those reactions take effect: 0, at t (the world waits for
  ACK(t) before it steps on); 1, at t + one period (pipelined: the world steps on at once
  and waits for ACK(t) at the next TICK);
* LEAVE (or silence longer than the world's --lockstep-timeout) stops the waiting.

Payload (MAVLink 2 wire order, largest type first): time_usec u64, period_usec u32,
target_system u8, kind u8, participant u8; then the extension lag u8 (trimmed when 0, so a
TICK with lag 0 is the same bytes as before the field existed).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

from pymavlink.generator.mavcrc import x25crc

from common.mavlink.signing import signature

MSG_ID = 43005
CRC_EXTRA = 32                  # mavgen's seed for TOWERLINK_LOCKSTEP (checked against the dialect)
JOIN, ACK, TICK, LEAVE = 1, 2, 3, 4
WORLD, BRIDGE, TOWER, OTHER = 0, 1, 2, 3
KIND_NAMES = {JOIN: "JOIN", ACK: "ACK", TICK: "TICK", LEAVE: "LEAVE"}
PARTICIPANT_NAMES = {WORLD: "world", BRIDGE: "bridge", TOWER: "tower", OTHER: "other"}
_PAYLOAD = struct.Struct("<QIBBBB")
_STX2 = 0xFD


@dataclass(frozen=True)
class Lockstep:
    """One decoded TOWERLINK_LOCKSTEP: sim time in microseconds, the sender's ids."""
    time_usec: int
    kind: int
    participant: int
    target_system: int
    period_usec: int
    sysid: int
    compid: int
    lag: int = 0        # TICK: frames until a reaction to it takes effect (0 or 1, see the module docstring)

    @property
    def t(self) -> float:
        """time_usec in sim seconds."""
        return self.time_usec / 1e6


def pack(kind: int, time_usec: int, *, participant: int = WORLD, target_system: int = 0,
         period_usec: int = 0, sysid: int = 1, compid: int = 1, seq: int = 0,
         signing: tuple[bytes, int, int] | None = None, lag: int = 0) -> bytes:
    """One MAVLink 2 frame of TOWERLINK_LOCKSTEP (trailing zero bytes trimmed).

    signing: (secret key, link_id, timestamp in 10 us units since 2015) signs the frame as
    MAVLink 2 does (common.mavlink.signing checks it); None: unsigned."""
    payload = _PAYLOAD.pack(int(time_usec) & 0xFFFFFFFFFFFFFFFF, int(period_usec) & 0xFFFFFFFF,
                            target_system & 0xFF, kind & 0xFF, participant & 0xFF, lag & 0xFF)
    n = len(payload)
    while n > 1 and payload[n - 1] == 0:
        n -= 1
    payload = payload[:n]
    header = struct.pack("<BBBBBBBHB", _STX2, n, 1 if signing else 0, 0, seq & 0xFF, sysid & 0xFF,
                         compid & 0xFF, MSG_ID & 0xFFFF, MSG_ID >> 16)
    crc = x25crc(header[1:] + payload)
    crc.accumulate(bytes((CRC_EXTRA,)))
    frame = header + payload + struct.pack("<H", crc.crc)
    if signing is None:
        return frame
    key, link_id, timestamp = signing
    return frame + signature(bytes(key), frame, link_id, timestamp)


def is_lockstep(data: bytes) -> bool:
    """Does this datagram start with a MAVLink 2 TOWERLINK_LOCKSTEP frame? (cheap test)"""
    return len(data) >= 12 and data[0] == _STX2 and data[7] | (data[8] << 8) | (data[9] << 16) == MSG_ID


def sender(data: bytes) -> tuple[int, int] | None:
    """(sysid, compid) from the header of the MAVLink frame `data` starts with, or None."""
    if len(data) >= 10 and data[0] == _STX2:
        return data[5], data[6]
    if len(data) >= 6 and data[0] == 0xFE:
        return data[3], data[4]
    return None


def unpack(data: bytes) -> tuple[Lockstep | None, bytes]:
    """The first frame of `data` if it is a valid TOWERLINK_LOCKSTEP, and the bytes after it.

    Returns (None, data) for anything else (another message, a bad CRC, a short frame):
    the caller hands those bytes on unchanged. Signed frames are read; the signature is
    the receiver's to check (common.mavlink.signing on ``data[:len(data) - len(rest)]``)."""
    if not is_lockstep(data):
        return None, data
    n, incompat = data[1], data[2]
    end = 10 + n + 2 + (13 if incompat & 1 else 0)
    if len(data) < 10 + n + 2:
        return None, data
    crc = x25crc(bytes(data[1:10 + n]))
    crc.accumulate(bytes((CRC_EXTRA,)))
    if crc.crc != struct.unpack_from("<H", data, 10 + n)[0]:
        return None, data
    payload = bytes(data[10:10 + n]) + bytes(_PAYLOAD.size - min(n, _PAYLOAD.size))
    time_usec, period, target, kind, who, lag = _PAYLOAD.unpack(payload[:_PAYLOAD.size])
    return Lockstep(time_usec, kind, who, target, period, data[5], data[6], lag), bytes(data[end:])


def read_checked(raw: bytes) -> Lockstep | None:
    """One whole TOWERLINK_LOCKSTEP frame whose CRC was already checked (a
    common.mavlink.frame_parser Packet's ``raw``), read without checking it again; None when
    it is another message."""
    if not is_lockstep(raw):        # (MAVLink 1 cannot carry its id)
        return None
    payload = bytes(raw[10:10 + min(raw[1], _PAYLOAD.size)])
    time_usec, period, target, kind, who, lag = _PAYLOAD.unpack(payload + bytes(_PAYLOAD.size - len(payload)))
    return Lockstep(time_usec, kind, who, target, period, raw[5], raw[6], lag)


def speedup_arg(text: str) -> float:
    """--speedup: a number > 0 (at most N times real time) or ``max`` (as fast as the slowest
    lockstep participant and the CPU allow): float('inf'). Raises ValueError."""
    if text.strip().lower() == "max":
        return float("inf")
    v = float(text)
    if not v > 0:
        raise ValueError(f"speedup must be > 0 or 'max', not {text!r}")
    return v


def speedup_type(text: str) -> float:
    """speedup_arg for argparse (`type=speedup_type`): a bad value is an ArgumentTypeError."""
    import argparse
    try:
        return speedup_arg(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def speedup_text(v: float) -> str:
    """The inverse of speedup_arg, for command lines and banners."""
    return "max" if v == float("inf") else f"{v:g}"
