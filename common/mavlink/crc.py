"""MAVLink's frame checksum: CRC-16/MCRF4XX (the "X.25 CRC": reflected 0x1021, init 0xFFFF).

Pure and at C speed: fastcrc's mcrf4xx when it is installed (pymavlink uses it too), else
binascii.crc_hqx, which computes the unreflected CRC-16/XMODEM in C: reflecting the input
bytes, the initial value and the result turns one into the other (a reflected CRC of the
data is the mirror of the unreflected CRC of the mirrored data from the mirrored start).
"""
from __future__ import annotations

from binascii import crc_hqx

try:  # the C implementation pymavlink picks when it is installed
    from fastcrc.crc16 import mcrf4xx as _fast
except ImportError:  # pragma: no cover - where fastcrc is missing
    _fast = None

X25_INIT = 0xFFFF

_MIRROR = bytes(int(f"{b:08b}"[::-1], 2) for b in range(256))


def _mirror16(c: int) -> int:
    return _MIRROR[c & 0xFF] << 8 | _MIRROR[c >> 8]


def x25crc_portable(data, crc: int = X25_INIT) -> int:
    """:func:`x25crc` from the standard library alone (binascii.crc_hqx)."""
    return _mirror16(crc_hqx(bytes(data).translate(_MIRROR), _mirror16(crc)))


def x25crc(data, crc: int = X25_INIT) -> int:
    """The X.25 CRC of bytes-like `data`, continuing from `crc` (default: a fresh one), so
    ``x25crc(b, x25crc(a)) == x25crc(a + b)``. A frame's is over everything after the magic
    byte up to the checksum, then the message's CRC_EXTRA byte."""
    if _fast is not None:
        return _fast(data, crc)
    return x25crc_portable(data, crc)
