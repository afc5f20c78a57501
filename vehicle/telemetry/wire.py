"""Putting simulated values into MAVLink's integer fields and time stamps."""
from __future__ import annotations


INT32 = (-2**31, 2**31 - 1)


def wire_clamp(v: float, lo: int, hi: int) -> int:
    """v rounded and clamped into [lo, hi]; 0 when not finite (a field cannot carry NaN)."""
    try:
        r = round(v)
    except (ValueError, OverflowError):     # NaN, +-inf (one try costs less than isfinite)
        return 0
    return lo if r < lo else hi if r > hi else int(r)


def e7(deg: float) -> int:
    """Degrees as MAVLink's int32 degE7."""
    return wire_clamp(deg * 1e7, *INT32)


def boot_ms(t: float) -> int:
    """time_boot_ms of sim time t (s): the world's clock is every vehicle's boot clock."""
    return int(t * 1000.0) & 0xFFFFFFFF


def usec(t: float) -> int:
    """time_usec (64-bit) of sim time t (s)."""
    return int(t * 1e6)
