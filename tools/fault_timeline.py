"""A run's fault timeline, resolved: what to do at which sim time, and the tower link's settings at any time (pure).

Built by `towerlink fly` from the scenario's [[faults]] (common.scenario_faults), the tower
link's own settings for the whole run (fly --tower-link / --tower-loss) and the parameters the
run starts with (fly --param, else each vehicle's defaults). Every vehicle parameter is checked
against that vehicle's table (name, range, whole number), so a typo fails before anything flies.

* :meth:`FaultTimeline.link_at` - the tower link's settings per direction at sim time t: the
  run's own, then every tower-link fault active at t in the order written;
* :attr:`FaultTimeline.events` - every apply and clear in time order, each with the parameter
  sets a vehicle fault sends (a clear sends the start values back);
* :class:`Cursor` - walks the events as a clock advances.
"""
from __future__ import annotations

import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from common.link_settings import DIRECTIONS, LinkSettings, per_direction
from common.scenario_faults import Fault

EPS = 1e-9          # s: a fault at t applies at a clock reading of t, however the sum rounded


@dataclass(frozen=True)
class ParamSet:
    """One PARAM_SET a fault sends: vehicle sysid, ArduPilot name, value, MAV_PARAM_TYPE."""
    sysid: int
    name: str
    value: float
    ptype: int


@dataclass(frozen=True)
class Event:
    """A fault applied or cleared at sim time t (params: what a vehicle fault sends then)."""
    t: float
    fault: int                      # the fault's index in the scenario
    kind: str                       # "apply" | "clear"
    params: tuple[ParamSet, ...] = ()


class FaultTimeline:
    """The resolved timeline (see the module doc). `kinds`: sysid -> "copter" | "rover";
    `tables`: kind -> {name: ParamDef}; `start`: parameter values the run starts with
    (fly --param), over the tables' defaults. ValueError for a parameter a vehicle lacks."""

    def __init__(self, faults: Sequence[Fault], base: Mapping[str, LinkSettings] | None = None,
                 kinds: Mapping[int, str] | None = None, tables: Mapping[str, Mapping] | None = None,
                 start: Mapping[str, float] | None = None) -> None:
        self.faults = tuple(faults)
        self.base = dict(base or {d: LinkSettings() for d in DIRECTIONS})
        self._link = [(f, per_direction(dict(f.link))) for f in self.faults if f.on_link]
        events: list[Event] = []
        for f in self.faults:
            sets = () if f.on_link else tuple(self._param_sets(f, kinds or {}, tables or {}, start or {}))
            events.append(Event(f.t, f.index, "apply", tuple(s for s, _ in sets)))
            if f.until is not None:
                events.append(Event(f.until, f.index, "clear", tuple(ParamSet(s.sysid, s.name, v, s.ptype)
                                                                      for s, v in sets)))
        self.events = tuple(sorted(events, key=lambda e: (e.t, e.kind == "apply", e.fault)))

    @staticmethod
    def _param_sets(f: Fault, kinds, tables, start) -> list[tuple[ParamSet, float]]:
        """(the fault's PARAM_SET, the value a clear sends back) per parameter; checked."""
        kind = kinds.get(f.sysid)
        table = tables.get(kind) if kind else None
        out = []
        for name, value in f.params:
            if table is None:
                raise ValueError(f"fault {f.index} ({f.describe()}): no vehicle with sysid {f.sysid} in this run")
            d = table.get(name)
            if d is None:
                close = difflib.get_close_matches(name, list(table), n=1)
                hint = f" (did you mean {close[0]}?)" if close else ""
                raise ValueError(f"fault {f.index} ({f.describe()}): the {kind} has no parameter {name}{hint}")
            if not d.lo <= value <= d.hi or (d.integer and value != int(value)):
                whole = ", a whole number" if d.integer else ""
                raise ValueError(f"fault {f.index} ({f.describe()}): {name} {value:g} is outside "
                                 f"{d.lo:g}..{d.hi:g}{whole}")
            out.append((ParamSet(f.sysid, name, float(value), d.mav_type), float(start.get(name, d.default))))
        return out

    @property
    def touches_link(self) -> bool:
        """Does the tower link ever differ from a perfect one?"""
        return any(s.active for s in self.base.values()) or bool(self._link)

    def link_at(self, t: float) -> dict[str, LinkSettings]:
        """{"up": ..., "down": ...}: the tower link's settings at sim time t."""
        out = dict(self.base)
        for f, changes in self._link:
            if f.t <= t + EPS and (f.until is None or t + EPS < f.until):
                out = {d: out[d].changed(changes[d]) for d in DIRECTIONS}
        return out

    def cursor(self) -> "Cursor":
        return Cursor(self.events)


class Cursor:
    """The events not yet passed; `advance(t)` returns those due by sim time t, in order."""

    def __init__(self, events: Sequence[Event]) -> None:
        self.events = list(events)
        self.next = 0

    def advance(self, t: float) -> list[Event]:
        start = self.next
        while self.next < len(self.events) and self.events[self.next].t <= t + EPS:
            self.next += 1
        return self.events[start:self.next]
