"""ArduPilot's DataFlash binary log format (the .BIN file): record framing, the format
characters, and encoders for FMT / UNIT / MULT / FMTU and any message definition.

A record is 0xA3 0x95 <type byte> followed by the packed little-endian payload; nothing
else: no length, no checksum. A reader learns each type's layout from the FMT records,
so FMT (type 128, fixed) must precede a type's first record. UNIT / MULT give the units
and multipliers, FMTU ties them to each message's fields (libraries/AP_Logger/LogStructure.h).

Values handed to `Encoder.pack` are the numbers pymavlink's DFReader gives back for that
field: a centi-scaled character (c C e E) takes the value / 100 of what is stored (so an
ATT.Roll 'c' field takes degrees), L takes degrees (stored as 1e-7 deg), every other
character takes the raw stored value. Integers are rounded and clamped to their type;
NaN and infinities are stored as 0. Strings are ASCII, NUL-padded, cut to the field.
"""
from __future__ import annotations

import math
import struct
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

HEAD = b"\xa3\x95"
FMT_TYPE = 128                  # LOG_FORMAT_MSG: the one fixed type id
MAX_TYPES = 255                 # 255 is reserved

# format character -> (struct code, scale applied before storing, integer range or None)
_INT_RANGES = {"b": (-2**7, 2**7 - 1), "B": (0, 2**8 - 1), "h": (-2**15, 2**15 - 1),
               "H": (0, 2**16 - 1), "i": (-2**31, 2**31 - 1), "I": (0, 2**32 - 1),
               "q": (-2**63, 2**63 - 1), "Q": (0, 2**64 - 1)}
FORMAT_CHARS: dict[str, tuple[str, float]] = {
    "a": ("32h", 1.0), "b": ("b", 1.0), "B": ("B", 1.0), "h": ("h", 1.0), "H": ("H", 1.0),
    "i": ("i", 1.0), "I": ("I", 1.0), "f": ("f", 1.0), "d": ("d", 1.0),
    "n": ("4s", 1.0), "N": ("16s", 1.0), "Z": ("64s", 1.0),
    "c": ("h", 100.0), "C": ("H", 100.0), "e": ("i", 100.0), "E": ("I", 100.0),
    "L": ("i", 1e7), "M": ("B", 1.0), "q": ("q", 1.0), "Q": ("Q", 1.0),
}


@dataclass(frozen=True)
class MessageDef:
    """One log message as ArduPilot declares it: name (4 chars at most), format (16),
    comma-separated labels (64), one unit id and one multiplier id per field."""
    name: str
    fmt: str
    labels: str
    units: str
    mults: str

    def __post_init__(self) -> None:
        n = len(self.fmt)
        cols = self.labels.split(",")
        if not 0 < len(self.name) <= 4 or n > 16 or len(self.labels) > 64:
            raise ValueError(f"{self.name}: name, format or labels too long")
        if len(cols) != n or len(self.units) != n or len(self.mults) != n:
            raise ValueError(f"{self.name}: {n} format characters, {len(cols)} labels, "
                             f"{len(self.units)} units, {len(self.mults)} multipliers")
        bad = set(self.fmt) - set(FORMAT_CHARS)
        if bad:
            raise ValueError(f"{self.name}: unknown format character(s) {''.join(sorted(bad))}")

    @property
    def columns(self) -> list[str]:
        return self.labels.split(",")


def _int_conv(scale: float, lo: int, hi: int) -> Callable[[float], int]:
    def conv(x) -> int:
        x = x * scale
        if not math.isfinite(x):
            return 0
        return min(max(round(x), lo), hi)
    return conv


def _str_conv(x) -> bytes:
    return x if isinstance(x, bytes) else str(x).encode("ascii", "replace")


def _array_conv(x) -> list[int]:
    c = _int_conv(1.0, -2**15, 2**15 - 1)
    vals = [c(v) for v in x][:32]
    return vals + [0] * (32 - len(vals))


class Encoder:
    """Packs records of one message type: `pack(*values)` -> the record's bytes (too few or
    too many values: TypeError or ValueError)."""

    def __init__(self, type_id: int, d: MessageDef) -> None:
        if not 0 <= type_id < MAX_TYPES:
            raise ValueError(f"type id {type_id} out of range")
        self.type_id = type_id
        self.d = d
        self.struct = struct.Struct("<3B" + "".join(FORMAT_CHARS[c][0] for c in d.fmt))
        self.size = self.struct.size            # whole record, header included
        self._head = (HEAD[0], HEAD[1], type_id)
        self._array = [i for i, c in enumerate(d.fmt) if c == "a"]
        convs = []
        for i, c in enumerate(d.fmt):
            code, scale = FORMAT_CHARS[c]
            if c in "nNZ":
                convs.append((i, _str_conv))
            elif c == "a":
                convs.append((i, _array_conv))
            elif c in "fd":
                continue
            else:
                lo, hi = _INT_RANGES[code]
                convs.append((i, _int_conv(scale, lo, hi)))
        self._convs = convs
        self.pack = self._fast_packer()

    def _fast_packer(self) -> Callable[..., bytes]:
        """pack() for the common case (`run_packer` of this one message)."""
        if any(c in "nNZa" for c in self.d.fmt):
            return self._pack_checked              # strings and arrays: the careful path
        return run_packer([self])

    def field_exprs(self, args: Sequence[str]) -> list[str]:
        """Python expressions of the struct values of this record's fields (header first) from
        the field values named `args`: each scaled and rounded inline, as `pack` stores them."""
        exprs = [str(b) for b in self._head]
        for a, c in zip(args, self.d.fmt):
            scale = FORMAT_CHARS[c][1]
            if c in "fd":
                exprs.append(a)
            elif scale == 1.0:              # an int as it is (round() gives it back), else rounded
                exprs.append(f"({a} if {a}.__class__ is _int else _round({a}))")
            else:
                exprs.append(f"_round({a} * {scale!r})")
        return exprs

    def _pack_checked(self, *values) -> bytes:
        """One record from the field values (as DFReader reads them back, see the module)."""
        if len(values) != len(self.d.fmt):
            raise ValueError(f"{self.d.name}: {len(self.d.fmt)} values expected, got {len(values)}")
        v = list(values)
        for i, conv in self._convs:
            v[i] = conv(v[i])
        if self._array:             # an int16[32] field takes 32 struct slots
            flat: list = []
            for i, x in enumerate(v):
                flat.extend(x) if i in self._array else flat.append(x)
            v = flat
        return self.struct.pack(*self._head, *v)


def run_packer(encoders: Sequence[Encoder]) -> Callable[..., bytes]:
    """pack(*values) of several records in a row (the values of each record after the one
    before's): their bytes as the encoders' `pack` give them, joined, from one struct call.
    Generated as one function (as dataclasses generate __init__): each field scaled and
    rounded inline, no per-field or per-record call. A value a record cannot store as is
    (NaN, infinite, out of its type's range) raises inside, and each record is packed again
    by its encoder's careful path, so the bytes are the same either way. No strings or
    arrays (they take the careful path always)."""
    args: list[str] = []
    exprs: list[str] = []
    slices = []
    for e in encoders:
        if any(c in "nNZa" for c in e.d.fmt):
            raise ValueError(f"{e.d.name}: strings and arrays are packed by the careful path")
        mine = [f"v{len(args) + i}" for i in range(len(e.d.fmt))]
        slices.append((e._pack_checked, len(args), len(args) + len(mine)))
        args += mine
        exprs += e.field_exprs(mine)
    fmt = "<" + "".join(e.struct.format.lstrip("<") for e in encoders)

    def checked(values: tuple) -> bytes:
        return b"".join(pack(*values[lo:hi]) for pack, lo, hi in slices)
    src = (f"def pack({', '.join(args)}):\n"
           f"    try:\n"
           f"        return _pack({', '.join(exprs)})\n"
           f"    except (ValueError, OverflowError, TypeError, struct.error):\n"
           f"        return _checked(({', '.join(args)},))\n")
    scope = {"_round": round, "_int": int, "_pack": struct.Struct(fmt).pack, "_checked": checked, "struct": struct}
    exec(src, scope)            # noqa: S102 - generated from the format strings above, no input
    return scope["pack"]


# FMT, UNIT, FMTU and MULT as LOG_COMMON_STRUCTURES declares them
FMT = MessageDef("FMT", "BBnNZ", "Type,Length,Name,Format,Columns", "-b---", "-----")
UNIT = MessageDef("UNIT", "QbZ", "TimeUS,Id,Label", "s--", "F--")
FMTU = MessageDef("FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds", "s---", "F---")
MULT = MessageDef("MULT", "Qbd", "TimeUS,Id,Mult", "s--", "F--")


class Schema:
    """The messages of one log with their type ids (FMT is 128, the rest numbered in the
    order given, skipping 128) and the records that declare them."""

    def __init__(self, defs: Iterable[MessageDef], units: Sequence[tuple[str, str]],
                 mults: Sequence[tuple[str, float]], first_id: int = 64) -> None:
        self.units = list(units)
        self.mults = list(mults)
        self.encoders: dict[str, Encoder] = {"FMT": Encoder(FMT_TYPE, FMT)}
        self._runs: dict[tuple[str, ...], Callable[..., bytes]] = {}
        next_id = first_id
        for d in (UNIT, FMTU, MULT, *defs):
            if d.name in self.encoders:
                raise ValueError(f"message {d.name} declared twice")
            if next_id == FMT_TYPE:
                next_id += 1
            self.encoders[d.name] = Encoder(next_id, d)
            next_id += 1
        if next_id > MAX_TYPES:
            raise ValueError("too many message types")
        unit_ids = {u for u, _ in self.units}
        mult_ids = {m for m, _ in self.mults}
        for e in self.encoders.values():
            if not set(e.d.units) <= unit_ids or not set(e.d.mults) <= mult_ids:
                raise ValueError(f"{e.d.name}: a unit or multiplier id the tables lack")

    def __getitem__(self, name: str) -> Encoder:
        return self.encoders[name]

    def packer(self, *names: str) -> Callable[..., bytes]:
        """`run_packer` of these messages in this order (built once per schema and order)."""
        run = self._runs.get(names)
        if run is None:
            run = self._runs[names] = run_packer([self.encoders[n] for n in names])
        return run

    def fmt_record(self, e: Encoder) -> bytes:
        d = e.d
        return self.encoders["FMT"].pack(e.type_id, e.size, d.name, d.fmt, d.labels)

    def header(self, time_us: int) -> bytes:
        """What opens a log: FMT for every message (FMT's own first), then UNIT, MULT, and
        FMTU for every message, as ArduPilot's log-start writer orders them."""
        out = [self.fmt_record(e) for e in self.encoders.values()]
        unit, mult, fmtu = self.encoders["UNIT"], self.encoders["MULT"], self.encoders["FMTU"]
        out += [unit.pack(time_us, ord(u), label) for u, label in self.units]
        out += [mult.pack(time_us, ord(m), value) for m, value in self.mults]
        out += [fmtu.pack(time_us, e.type_id, e.d.units, e.d.mults)
                for e in self.encoders.values() if e.type_id != FMT_TYPE]
        return b"".join(out)
