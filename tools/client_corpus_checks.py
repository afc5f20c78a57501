"""The client corpus's pure core: what the vehicle was seen to do while a program ran (a
:class:`Record`), and the checks of a program's manifest entry evaluated against it.

A check is a short string (examples/clients/corpus.toml):

    alt>=9        the highest relative altitude seen (GLOBAL_POSITION_INT, m, up) was at least 9
    alt<1         ... stayed below 1
    dist>=40      the farthest horizontal distance from where the vehicle first was (m)
    roll>=20      the largest |roll| seen (ATTITUDE, degrees)
    mode:LAND     the vehicle was seen in this ArduCopter mode; !mode:AUTO never
    armed         it was armed at some point; !armed never
    disarmed      it ended disarmed (the runner waits up to `settle` s for this)
    text:REGEX    a STATUSTEXT matched; !text:REGEX none did
    out:REGEX     the program's output matched; !out:REGEX it did not
    msg:NAME      a message of this type was heard by the watcher
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field


@dataclass
class Record:
    """The vehicle as a second ground station heard it during one program's run."""

    modes: list[str] = field(default_factory=list)     # each mode as first seen, in order
    armed_ever: bool = False
    armed_now: bool = False
    max_alt: float = 0.0                                 # m above home (up)
    max_dist: float = 0.0                                # m, horizontal, from the first fix
    max_roll: float = 0.0                                # degrees, absolute
    texts: list[str] = field(default_factory=list)       # STATUSTEXT, in order
    types: set[str] = field(default_factory=set)
    first_fix: tuple[float, float] | None = None         # (lat, lon) degrees

    def heartbeat(self, mode: str, armed: bool) -> None:
        if not self.modes or self.modes[-1] != mode:
            self.modes.append(mode)
        self.armed_now = armed
        self.armed_ever = self.armed_ever or armed

    def position(self, lat: float, lon: float, rel_alt: float) -> None:
        """lat, lon in degrees; rel_alt in m above home, up."""
        if self.first_fix is None:
            if lat == 0 and lon == 0:
                return
            self.first_fix = (lat, lon)
        self.max_alt = max(self.max_alt, rel_alt)
        dn = (lat - self.first_fix[0]) * 111_319.5
        de = (lon - self.first_fix[1]) * 111_319.5 * math.cos(math.radians(lat))
        self.max_dist = max(self.max_dist, math.hypot(dn, de))

    def attitude(self, roll_rad: float) -> None:
        self.max_roll = max(self.max_roll, abs(math.degrees(roll_rad)))

    def summary(self) -> str:
        """One line for a report: modes, arming, the extremes."""
        return (f"modes {'>'.join(self.modes) or '-'}; armed {'yes' if self.armed_ever else 'no'}"
                f"{' (still)' if self.armed_now else ''}; alt {self.max_alt:.1f} m; dist {self.max_dist:.1f} m")


_NUMERIC = re.compile(r"^(alt|dist|roll)(>=|<)(-?[0-9.]+)$")


def check_failure(check: str, rec: Record, output: str) -> str | None:
    """None when `check` holds for this run, else why not (one short phrase)."""
    m = _NUMERIC.match(check)
    if m:
        what, op, limit = m.group(1), m.group(2), float(m.group(3))
        got = {"alt": rec.max_alt, "dist": rec.max_dist, "roll": rec.max_roll}[what]
        ok = got >= limit if op == ">=" else got < limit
        unit = "deg" if what == "roll" else "m"
        return None if ok else f"max {what} {got:.1f} {unit}, wanted {op}{limit:g}"
    negate = check.startswith("!")
    body = check[1:] if negate else check
    kind, _, arg = body.partition(":")
    if kind == "mode":
        seen = arg in rec.modes
    elif kind == "text":
        seen = any(re.search(arg, t) for t in rec.texts)
    elif kind == "out":
        seen = re.search(arg, output, re.MULTILINE) is not None
    elif kind == "msg":
        seen = arg in rec.types
    elif kind == "armed":
        seen = rec.armed_ever
    elif kind == "disarmed":
        seen = not rec.armed_now
    else:
        raise ValueError(f"unknown check {check!r}")
    if seen != negate:
        return None
    label = {"mode": "mode", "text": "STATUSTEXT", "out": "output", "msg": "message"}.get(kind, kind)
    if kind in ("armed", "disarmed"):
        return f"{'was' if negate else 'never'} {kind}" if kind == "armed" else \
            ("ended disarmed" if negate else "still armed at the end")
    return f"{label} {arg!r} {'seen' if negate else 'not seen'}"


def failures(checks: list[str], rec: Record, output: str, returncode: int | None,
             want_exit: int | None, timed_out: bool) -> list[str]:
    """Every reason this run differs from the expectation (empty: it behaves). With any exit
    wanted (want_exit None) a program that hangs after failing as expected behaves too (MAVSDK
    3.x's programs do not exit after an uncaught error while their server thread lives)."""
    out = []
    if timed_out and want_exit is not None:
        out.append("timed out")
    elif want_exit is not None and returncode != want_exit:
        out.append(f"exit {returncode}, wanted {want_exit}")
    for c in checks:
        why = check_failure(c, rec, output)
        if why:
            out.append(why)
    if out:
        said = last_failure(output)
        if said:
            out.append(said)
    return out


_SAID_FAILED = re.compile(r"^(?:MAVPROXY-SCRIPT )?FAILED: (.*)$")


def last_failure(output: str) -> str | None:
    """What the program said about its failure: its own last 'FAILED: ...' line (the autotest
    and MAVProxy programs), else the last exception it raised."""
    said = [m.group(1) for line in output.splitlines() if (m := _SAID_FAILED.match(line.strip()))]
    if said:
        return f"it said: {said[-1][:160]}"
    raised = last_exception(output)
    return f"it raised {raised}" if raised else None


_EXCEPTION = re.compile(r"^([A-Za-z_][\w.]*(?:Error|Exception|Exit)): ?(.*)$")


def last_exception(output: str) -> str | None:
    """The last 'SomeError: text' line a program printed (a traceback's last line), shortened."""
    found = None
    for line in output.splitlines():
        m = _EXCEPTION.match(line.strip())
        if m:
            found = f"{m.group(1).rsplit('.', 1)[-1]}: {m.group(2).split('; origin:')[0]}"[:160]
    return found
