"""The vehicles' parameter tables, for the tools that set parameters on a run (fly --param, a
sweep's parameter factors, a scenario's vehicle faults): which names exist, their ranges, types
and defaults, per vehicle kind."""
from __future__ import annotations

from typing import Any


def param_table(kind: str | None = None) -> dict[str, Any]:
    """name -> ParamDef (vehicle.autopilot.param_def) of a "copter" or a "rover"; None: every
    name either knows (the copter's definition where both have one)."""
    from vehicle.autopilot.params import COPTER_TABLE, ROVER_TABLE, core_table
    kinds = ("copter", "rover") if kind is None else (kind,)
    table: dict[str, Any] = {}
    for k in kinds:
        for d in [*core_table(k), *(COPTER_TABLE if k == "copter" else ROVER_TABLE)]:
            table.setdefault(d.name, d)
    return table
