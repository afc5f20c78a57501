"""@PARAM/param.pck: the parameter list in ArduPilot's packed format (AP_Filesystem_Param),
what MAVProxy and QGroundControl download over MAVFTP before falling back to
PARAM_REQUEST_LIST."""
from __future__ import annotations

import struct

PCK_MAGIC, PCK_MAGIC_DEFAULTS = 0x671B, 0x671C
# ArduPilot's AP_PARAM type codes and struct formats, by MAV_PARAM_TYPE
_PCK_TYPES = {2: (1, "b"), 1: (1, "b"), 4: (2, "h"), 3: (2, "h"), 6: (3, "i"), 5: (3, "i"), 9: (4, "f")}


def param_pck(entries, with_defaults: bool = False) -> bytes:
    """entries: (name, value, MAV_PARAM_TYPE, default) in index order -> the file's bytes.

    Header <HHH: magic (0x671c with defaults), parameter count, total count; then per
    parameter: a byte of AP type (low nibble) and flags (bit 4: a default follows), a byte of
    (name suffix length - 1) << 4 | length of the prefix shared with the previous name (<= 15),
    the name suffix, the value, and with defaults the default when it differs."""
    out = [struct.pack("<HHH", PCK_MAGIC_DEFAULTS if with_defaults else PCK_MAGIC, len(entries), len(entries))]
    last = b""
    for name, value, mav_type, default in entries:
        code, fmt = _PCK_TYPES.get(mav_type, (4, "f"))
        nb = name.encode("ascii")[:16]
        common = 0
        while common < min(15, len(last), len(nb) - 1) and last[common] == nb[common]:
            common += 1
        suffix = nb[common:]
        flags = 0
        vals = [value]
        if with_defaults and value != default:
            flags, vals = 1, [value, default]
        if fmt != "f":
            vals = [round(v) for v in vals]
        out.append(struct.pack("<BB", code | flags << 4, (len(suffix) - 1) << 4 | common) + suffix
                   + struct.pack("<" + fmt * len(vals), *vals))
        last = nb
    return b"".join(out)
