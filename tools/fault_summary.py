"""The summary's fault section: each fault of the run, when it took effect and was cleared, the
failsafes it caused, and what became of the mission (pure data work: no sockets).

Inputs: the scenario's faults (common.scenario_faults.Fault), when the link proxy applied and
cleared each (faults.json, sim s: in lockstep the first lockstep frame at or after the fault's
time; a vehicle's fault in a pipelined lockstep the frame after it), the vehicles' STATUSTEXTs and mode changes (tools.run_data: texts, modes; sim s) and the
tower's goals. A failsafe is a vehicle's STATUSTEXT that says so (ArduPilot's words: "GCS
Failsafe On: RTL", "Battery Failsafe", the monitor's "Battery 1 is low ...", the EKF check's
"EKF variance" and "EKF Failsafe: changed to LAND Mode"; a "... Cleared" is not one, nor is the
warning "GPS Glitch"). It is put down to the
latest fault applied before it of the kind that can cause it: a GCS failsafe (the ground
station fell silent) to a tower-link fault, a battery one to a fault on the vehicle's battery
parameters, an EKF or GPS one to a fault on its sensors or motors (SIM_GPS*, SIM_BARO*,
SIM_ENGINE_*...), any other to a fault on that vehicle; failing that,
to the latest fault on either (none: a failsafe without a fault). Its mode is the vehicle's
mode a heartbeat period (HEARTBEAT_S) later, when its HEARTBEAT has told it.
"""
from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from common.scenario_faults import Fault
from tools.run_data import RunData

EPS = 1e-6
HEARTBEAT_S = 1.0       # s between a vehicle's HEARTBEATs (ArduPilot's 1 Hz)


_BATTERY_LEVEL = re.compile(r"^Battery \d+ is (low|critical)\b")


# what the EKF check says as its failsafe triggers (ArduCopter's words)
_ESTIMATOR = ("EKF variance",)


def is_failsafe(text: str) -> bool:
    """Does this STATUSTEXT report a failsafe (not its clearing)? The vehicle's own ("GCS Failsafe
    On: RTL", "Battery Failsafe", "EKF Failsafe: changed to LAND Mode"), the battery monitor's
    level ("Battery 1 is low 10.20V ...", which a vehicle whose BATT_FS_LOW_ACT is 0 says
    alone) and the EKF check's "EKF variance". Not "GPS Glitch": a warning, its failsafe (if any)
    is the EKF check's."""
    t = text.lower()
    return ("failsafe" in t and "cleared" not in t) or bool(_BATTERY_LEVEL.match(text)) or text in _ESTIMATOR


def fault_section(faults: Sequence[Fault], applied: Sequence[Mapping[str, Any]], data: RunData,
                  names: Mapping[int, str], goals: Sequence[Mapping[str, Any]],
                  end: float | None = None) -> dict[str, Any]:
    """{"faults": [...], "failsafes": [...], "goals_reached_after_first_fault": n | None} (see the
    module doc). `end`: the tower's end (sim s): what the vehicles said after it, while fly
    stopped the processes, lasted as long as the machine took, so it is no failsafe of the run's."""
    at = {(a["fault"], a["kind"]): float(a["at"]) for a in applied}
    events = []
    for sysid in sorted(data.texts):
        for t, severity, text in data.texts[sysid]:
            if is_failsafe(text) and (end is None or t <= end + EPS):
                events.append({"vehicle": names.get(sysid, f"sysid {sysid}"), "sysid": sysid, "text": text,
                               "t": t, "mode": _mode_at(data, sysid, t), "fault": None})
    rows = []
    for f in faults:
        on, off = at.get((f.index, "apply")), at.get((f.index, "clear"))
        rows.append({**f.as_dict(), "applied": on, "cleared": off, "failsafes": [],
                     "goals_reached_after": _reached_after(goals, on)})
    for e in events:
        cause = _cause(faults, at, e["sysid"], e["t"], e["text"])
        if cause is not None:
            e["fault"] = cause.index
            e["after"] = e["t"] - at[(cause.index, "apply")]
            rows[cause.index]["failsafes"].append({k: v for k, v in e.items() if k != "fault"})
    firsts = [at[(f.index, "apply")] for f in faults if (f.index, "apply") in at]
    return {"faults": rows, "failsafes": events,
            "goals_reached_after_first_fault": _reached_after(goals, min(firsts)) if firsts else None}


def _cause(faults: Sequence[Fault], at: Mapping, sysid: int, t: float, text: str) -> Fault | None:
    """The fault a failsafe is put down to (see the module doc); None: none applied by then."""
    before = [f for f in faults if at.get((f.index, "apply")) is not None
              and at[(f.index, "apply")] <= t + EPS and (f.on_link or f.sysid == sysid)]
    if not before:
        return None
    likely = [f for f in before if _can_cause(f, text)] or before
    return max(likely, key=lambda f: (at[(f.index, "apply")], f.index))


# a vehicle failsafe's words -> the parameters (by prefix) of the faults that can cause it
_CAUSES = (("battery", ("SIM_BATT", "BATT_")),
           ("ekf", ("SIM_GPS", "SIM_BARO", "SIM_ACC", "SIM_GYR", "SIM_ENGINE", "SIM_MAG", "FS_EKF")),
           ("gps", ("SIM_GPS",)))


def _can_cause(f: Fault, text: str) -> bool:
    """Can fault f cause this failsafe? A GCS failsafe comes from the tower link; a battery,
    EKF or GPS one from a vehicle fault on those parameters; any other from a vehicle fault."""
    t = text.lower()
    if f.on_link or "gcs" in t:
        return f.on_link and "gcs" in t
    for word, prefixes in _CAUSES:
        if word in t:
            return any(name.startswith(prefixes) for name, _ in f.params)
    return True


def _mode_at(data: RunData, sysid: int, t: float) -> str | None:
    """The vehicle's mode a heartbeat period after sim time t (None: never heard)."""
    mode = None
    for when, m, _armed in data.modes.get(sysid) or []:
        if when > t + HEARTBEAT_S + EPS:
            break
        mode = m
    return mode


def _reached_after(goals: Sequence[Mapping[str, Any]], t: float | None) -> int | None:
    if t is None:
        return None
    return sum(1 for g in goals if g.get("reached") and g.get("reached_sim") is not None and g["reached_sim"] >= t)


def first_failsafe_delay(section: Mapping[str, Any] | None) -> float | None:
    """Sim s from a fault to the first failsafe it caused, the earliest over the run (None: none)."""
    delays = [fs["after"] for row in (section or {}).get("faults", []) for fs in row.get("failsafes", [])]
    return min(delays) if delays else None


def format_faults(section: Mapping[str, Any] | None) -> list[str]:
    """The section's lines for summary.txt ([] when the run had no fault and no failsafe)."""
    if not section or not (section.get("faults") or section.get("failsafes")):
        return []
    lines = ["faults (sim s; in lockstep one takes effect at a lockstep frame at or after its t, at any speed):"]
    for row in section.get("faults", []):
        head = f"  [{row['index']}] t {row['t']:g} {row['target']} {row['what']}"
        if row.get("until") is not None:
            head += f" until {row['until']:g}"
        if row.get("applied") is None:
            lines.append(head + ": never applied (the run ended first)")
            continue
        when = f"applied {row['applied']:.2f}" + (f", cleared {row['cleared']:.2f}" if row.get("cleared") is not None else "")
        after = row.get("goals_reached_after")
        lines.append(f"{head}: {when}; goals reached after it: {after}")
        for fs in row["failsafes"]:
            lines.append(f"        -> {fs['vehicle']}: {fs['text']!r} at {fs['t']:.2f} (+{fs['after']:.2f} s), "
                         f"mode {fs['mode'] or '?'}")
        if not row["failsafes"]:
            lines.append("        -> no failsafe")
    loose = [e for e in section.get("failsafes", []) if e.get("fault") is None]
    for e in loose:
        lines.append(f"  failsafe without a fault: {e['vehicle']}: {e['text']!r} at {e['t']:.2f}, mode {e['mode'] or '?'}")
    return lines
