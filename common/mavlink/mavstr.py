"""MAVLink char[] fields (param_id, STATUSTEXT text, frame names) as Python strings.

A MAVLink string fills its field and is NUL-terminated only when shorter; pymavlink hands it
over as str or bytes, sometimes with the NULs and whatever followed them still attached.
"""
from __future__ import annotations


def mav_str(v: str | bytes | bytearray) -> str:
    """The text before the first NUL; bytes decoded as UTF-8, bad bytes replaced (never raises)."""
    if isinstance(v, (bytes, bytearray)):
        v = bytes(v).decode("utf-8", errors="replace")
    return str(v).split("\x00", 1)[0]
