"""A scenario's fault timeline, the ``[[faults]]`` tables: at sim time t, this fault, there (pure).

Each table is one fault::

    [[faults]]
    t = 12.0                   # sim s when it starts
    target = "tower_link"      # the tower's link to the bridge
    loss = 1.0                 # link settings (common/link_settings.py): both directions,
    up.latency = 0.3           # or one (up: towards the vehicles, down: back)
    until = 20.0               # optional: sim s when it is cleared (or duration = 8.0: s after t)

    [[faults]]
    t = 30.0
    target = "drone"           # a vehicle by name ("drone", "rover", a family's "drone2", the van)
    SIM_BATT_VOLTAGE = 10.0    # or by index: "vehicle:0" (sysid 1); parameters by ArduPilot name

A vehicle fault sets parameters on the vehicle (ArduPilot SITL's SIM_* faults, or any other
parameter); `until` sets them back to the values the run started with. A tower-link fault
changes the link's settings; `until` takes that change away again (faults that overlap apply
in the order they are written). Which parameter names a vehicle knows is checked when the run
is planned (tools.fault_timeline), not here: the scenario file does not know the vehicles'
parameter tables.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from common.link_settings import DIRECTIONS, SETTINGS, check_setting, describe_changes

TOWER_LINK = "tower_link"
PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")       # ArduPilot: at most 16 characters
MAX_T = 1e6                                             # sim s: a time beyond any run


@dataclass(frozen=True)
class Fault:
    """One entry of the timeline. `sysid` None is the tower link; `link` holds its changes
    as written ("loss", "up.latency": value), `params` a vehicle's (name, value) pairs."""
    index: int                                  # its place in the scenario's [[faults]]
    t: float                                    # sim s
    target: str                                 # as written
    sysid: int | None
    params: tuple[tuple[str, float], ...] = ()
    link: tuple[tuple[str, float], ...] = ()
    until: float | None = None

    @property
    def on_link(self) -> bool:
        return self.sysid is None

    def what(self) -> str:
        """'loss=1 up.latency=0.3' or 'SIM_BATT_VOLTAGE=10'."""
        return describe_changes(dict(self.link if self.on_link else self.params))

    def describe(self) -> str:
        """'t 12 tower_link loss=1 until 20'."""
        until = f" until {self.until:g}" if self.until is not None else ""
        return f"t {self.t:g} {self.target} {self.what()}{until}"

    def as_dict(self) -> dict[str, Any]:
        return {"index": self.index, "t": self.t, "target": self.target, "sysid": self.sysid,
                "what": self.what(), "until": self.until}


def parse_faults(tables: Any, vehicles: Sequence[tuple[str, int, str]],
                 fail: Callable[[str], Exception]) -> tuple[Fault, ...]:
    """The [[faults]] tables, checked. `vehicles`: (name, sysid, kind) of the scenario's vehicles;
    `fail(message)` makes the error to raise (the scenario's ScenarioError, naming the file)."""
    if tables is None:
        return ()
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise fail("faults must be a list of [[faults]] tables (t = sim s, target = ..., what to change)")
    return tuple(_fault(k, t, vehicles, fail) for k, t in enumerate(tables))


def resolve_target(target: Any, vehicles: Sequence[tuple[str, int, str]]) -> int | None:
    """The sysid a target names (None: the tower link); ValueError if it names nothing."""
    names = {name: sysid for name, sysid, _kind in vehicles}
    if target == TOWER_LINK:
        return None
    if isinstance(target, str) and target in names:
        return names[target]
    m = re.fullmatch(r"vehicle:(\d+)", target) if isinstance(target, str) else None
    if m and int(m.group(1)) < len(vehicles):
        return sorted(names.values())[int(m.group(1))]
    known = [TOWER_LINK, *names, *(f"vehicle:{i}" for i in range(len(vehicles)))]
    raise ValueError(f"target {target!r} is not {', '.join(repr(k) for k in known)}")


def _time(value: Any, where: str, fail) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise fail(f"{where} must be a finite number of sim seconds, got {value!r}")
    if not 0.0 <= value <= MAX_T:
        raise fail(f"{where} {value:g} s is outside 0..{MAX_T:g} s (sim time)")
    return float(value)


def _fault(k: int, table: dict[str, Any], vehicles, fail) -> Fault:
    where = f"faults[{k}]"
    if "t" not in table:
        raise fail(f"{where}: no t (the sim time in s when the fault starts)")
    if "target" not in table:
        raise fail(f"{where}: no target ({TOWER_LINK!r} or a vehicle: a name, or 'vehicle:0' for sysid 1)")
    t = _time(table["t"], f"{where}.t", fail)
    until = None
    if "until" in table and "duration" in table:
        raise fail(f"{where}: give until (sim s) or duration (s after t), not both")
    if "duration" in table:
        duration = _time(table["duration"], f"{where}.duration", fail)
        if duration <= 0:
            raise fail(f"{where}: duration must be > 0 s")
        until = t + duration
    if "until" in table:
        until = _time(table["until"], f"{where}.until", fail)
        if until <= t:
            raise fail(f"{where}: until {until:g} s is not after t {t:g} s")
    try:
        sysid = resolve_target(table["target"], vehicles)
    except ValueError as exc:
        raise fail(f"{where}: {exc}") from None
    rest = {key: v for key, v in table.items() if key not in ("t", "target", "until", "duration")}
    if sysid is None:
        link = _link_changes(rest, where, fail)
        return Fault(k, t, TOWER_LINK, None, link=link, until=until)
    params = []
    for name, value in rest.items():
        if not PARAM_NAME.match(name):
            raise fail(f"{where}: {name!r} is not a parameter name (a vehicle fault sets parameters by their "
                       f"ArduPilot names, e.g. SIM_BATT_VOLTAGE = 10.0)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise fail(f"{where}.{name} must be a finite number, got {value!r}")
        params.append((name, float(value)))
    if not params:
        raise fail(f"{where}: a fault on {table['target']!r} sets at least one parameter (e.g. SIM_BATT_VOLTAGE = 10.0)")
    return Fault(k, t, str(table["target"]), sysid, params=tuple(params), until=until)


def _link_changes(rest: dict[str, Any], where: str, fail) -> tuple[tuple[str, float], ...]:
    out: list[tuple[str, float]] = []
    for key, value in rest.items():
        if key in DIRECTIONS and isinstance(value, dict):
            items = [(f"{key}.{name}", v) for name, v in value.items()]
        elif key in SETTINGS:
            items = [(key, value)]
        else:
            raise fail(f"{where}: {key!r} is not a link setting ({', '.join(SETTINGS)}, each also in up = {{...}} "
                       f"or down = {{...}}); parameters belong to a vehicle's fault")
        for name, v in items:
            try:
                check_setting(name.rpartition(".")[2], v)
            except ValueError as exc:
                raise fail(f"{where}.{name}: {exc}") from None
            out.append((name, float(v)))
    if not out:
        raise fail(f"{where}: a tower_link fault changes at least one link setting ({', '.join(SETTINGS)})")
    return tuple(out)
