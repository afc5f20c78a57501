"""The sweep's table: one row per run, flattened from summary.json; the factors' effects (pure).

A row holds the run id, its factors (one column each, named as the factor), `pass` and `reason`,
`wall_s` (wall seconds the run took), the key figures below, then every numeric figure of the
run's summary.json flattened with dotted names (`follow_error.rms`, `goals.2.ratio`, ...).

Key figures (derived, so every row has them whatever the scenario):
  follow_rms      m    the rover's follow error RMS (truth, over the mission)
  wobble_rms      m    the ground-point wobble RMS of the frame the rover followed
  ratio_mean      -    mean over the goals of reach time / minimum time
  ratio_max       -    the worst goal's ratio
  mission_s       s    sim seconds from the first goal sent to the last reached
  failsafe_s      s    sim seconds from a fault to the first failsafe it caused (none: empty)
"""
from __future__ import annotations

import math
import statistics
from typing import Any, Iterable, Mapping

KEY_FIGURES = ("follow_rms", "wobble_rms", "ratio_mean", "ratio_max", "mission_s", "failsafe_s")
FIXED_COLUMNS = ("run_id", "pass", "reason", "wall_s")
# figures that measure the machine, not the mission (the wall clock); kept out of the table
WALL_FIELDS = {"achieved_speedup"}
SKIP_KEYS = {"ports", "commands", "text"}


def flatten(d: Any, prefix: str = "") -> dict[str, float]:
    """Every finite number in a nested summary (dicts and lists), with dotted names.
    Booleans become 0/1; strings, None and non-finite numbers are left out."""
    out: dict[str, float] = {}
    if isinstance(d, Mapping):
        items: Iterable = d.items()
    elif isinstance(d, (list, tuple)):
        items = ((str(i), v) for i, v in enumerate(d))
    else:
        return out
    for k, v in items:
        if k in SKIP_KEYS or (not prefix and k in WALL_FIELDS):
            continue
        name = f"{prefix}{k}"
        if isinstance(v, bool):
            out[name] = float(v)
        elif isinstance(v, (int, float)):
            if math.isfinite(v):
                out[name] = float(v)
        elif isinstance(v, (Mapping, list, tuple)):
            out.update(flatten(v, name + "."))
    return out


def key_figures(s: Mapping[str, Any]) -> dict[str, float | None]:
    """The figures the plots and the effects table use (None when the run has none)."""
    from tools.fault_summary import first_failsafe_delay
    fe = s.get("follow_error") or {}
    wob = s.get("wobble") or {}
    frame = wob.get("follow_frame") or s.get("follow_frame") or "drone_yaw"
    wf = wob.get(frame) if isinstance(wob.get(frame), Mapping) else {}
    ratios = [g["ratio"] for g in s.get("goals") or [] if isinstance(g.get("ratio"), (int, float))]
    win = s.get("mission_window_sim") or [None, None]
    mission = (win[1] - win[0]) if len(win) == 2 and all(isinstance(x, (int, float)) for x in win) else None
    return {"follow_rms": _num(fe.get("rms")), "wobble_rms": _num(wf.get("rms")),
            "ratio_mean": statistics.fmean(ratios) if ratios else None,
            "ratio_max": max(ratios) if ratios else None, "mission_s": _num(mission),
            "failsafe_s": _num(first_failsafe_delay(s.get("faults")))}


def _num(x: Any) -> float | None:
    return float(x) if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) else None


def make_row(run_id: str, factors: Mapping[str, Any], summary: Mapping[str, Any] | None, *,
             wall_s: float | None, reason: str | None = None) -> dict[str, Any]:
    """One table row. pass = the run's summary says ok and nothing failed around it; reason
    says why not (the runner's reason first, else the tower's error, else the goals missed)."""
    from tools.sweep_grid import format_value
    row: dict[str, Any] = {"run_id": run_id}
    for k, v in factors.items():
        row[k] = v if isinstance(v, (int, float, str)) and not isinstance(v, bool) else format_value(v)
    ok = bool(summary and summary.get("ok")) and reason is None
    if not ok and reason is None:
        if not summary:
            reason = "no summary"
        else:
            reason = summary.get("tower_error") or summary.get("error") or \
                f"{summary.get('goals_reached', 0)}/{summary.get('goals_total', '?')} goals reached" + \
                _first_failsafe(summary)
    row.update({"pass": ok, "reason": "" if ok else str(reason), "wall_s": wall_s})
    if summary:
        row.update(key_figures(summary))
        for k, v in flatten(summary).items():
            row.setdefault(k, v)
    else:
        row.update({k: None for k in KEY_FIGURES})
    return row


def _first_failsafe(summary: Mapping[str, Any]) -> str:
    """'; after drone: 'GCS Failsafe On: RTL' at 24.26 s' (the run's first failsafe), or ''."""
    events = (summary.get("faults") or {}).get("failsafes") or []
    if not events:
        return ""
    e = min(events, key=lambda x: x["t"])
    return f"; after {e['vehicle']}: {e['text']!r} at {e['t']:.2f} s"


def columns(rows: list[Mapping[str, Any]], factor_names: Iterable[str]) -> list[str]:
    """Column order: run_id, the factors, pass, reason, wall_s, key figures, then the rest A-Z."""
    head = ["run_id", *factor_names, "pass", "reason", "wall_s", *KEY_FIGURES]
    seen = dict.fromkeys(head)
    rest = sorted({k for r in rows for k in r} - set(seen))
    return head + rest


def normalise(rows: list[Mapping[str, Any]], cols: list[str]) -> list[dict[str, Any]]:
    """Rows with every column; a column is all numbers (float; ints kept when all are ints),
    all booleans, or text (mixed columns become text), so CSV and Parquet agree."""
    out = [{c: r.get(c) for c in cols} for r in rows]
    for c in cols:
        vals = [r[c] for r in out if r[c] is not None]
        if not vals or all(isinstance(v, bool) for v in vals):
            continue
        if all(isinstance(v, int) and not isinstance(v, bool) for v in vals):
            continue
        if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
            for r in out:
                if r[c] is not None:
                    r[c] = float(r[c])
            continue
        from tools.sweep_grid import format_value
        for r in out:
            if r[c] is not None and not isinstance(r[c], str):
                r[c] = format_value(r[c])
    return out


# ----------------------------------------------------------------------------- effects

EFFECT_FIGURES = ("follow_rms", "wobble_rms", "ratio_mean")


def effect_figures(rows: list[Mapping[str, Any]]) -> tuple[str, ...]:
    """The figures the effects table shows: the three above, and failsafe_s when a run had one."""
    extra = ("failsafe_s",) if any(_num(r.get("failsafe_s")) is not None for r in rows) else ()
    return EFFECT_FIGURES + extra


def effects(rows: list[Mapping[str, Any]], factors: Iterable[str],
            figures: Iterable[str] = EFFECT_FIGURES) -> list[dict[str, Any]]:
    """Per factor and level: runs, pass rate, and mean/std of each figure over the runs that
    have it. Levels in first-seen order (numbers sorted)."""
    figures = list(figures)
    out = []
    for f in factors:
        levels: dict[Any, list[Mapping[str, Any]]] = {}
        for r in rows:
            levels.setdefault(r.get(f), []).append(r)
        keys = list(levels)
        if all(isinstance(k, (int, float)) and not isinstance(k, bool) for k in keys):
            keys.sort()
        for level in keys:
            rs = levels[level]
            entry: dict[str, Any] = {"factor": f, "level": level, "runs": len(rs),
                                     "pass_rate": sum(bool(r.get("pass")) for r in rs) / len(rs)}
            for fig in figures:
                xs = [float(r[fig]) for r in rs if _num(r.get(fig)) is not None]
                entry[f"{fig}_mean"] = statistics.fmean(xs) if xs else None
                entry[f"{fig}_std"] = statistics.stdev(xs) if len(xs) > 1 else (0.0 if xs else None)
            out.append(entry)
    return out


def format_effects(eff: list[Mapping[str, Any]],
                   figures: Iterable[str] = EFFECT_FIGURES) -> str:
    """The effects as a short fixed-width table (mean ± std per figure, pass rate)."""
    from tools.sweep_grid import format_value
    figures = list(figures)
    head = f"{'factor':<16} {'level':<14} {'runs':>4} {'pass':>5}" + "".join(f" {f:>17}" for f in figures)
    lines = [head, "-" * len(head)]
    for e in eff:
        cells = ""
        for f in figures:
            m, s = e.get(f"{f}_mean"), e.get(f"{f}_std")
            cells += f" {'-':>17}" if m is None else f" {f'{m:.3f} ± {s:.3f}':>17}"
        level = format_value(e["level"]) if e["level"] is not None else "-"
        lines.append(f"{e['factor'][:16]:<16} {level[:14]:<14} {e['runs']:>4} {e['pass_rate']:>5.0%}{cells}")
    return "\n".join(lines)


def summary_line(rows: list[Mapping[str, Any]], wall_s: float, skipped: int = 0) -> str:
    """'12 runs (3 resumed), 1 failed, 95 s wall, 7.6 runs/min'."""
    n = len(rows)
    failed = sum(not r.get("pass") for r in rows)
    done = n - skipped
    rate = f"{60.0 * done / wall_s:.1f} runs/min" if wall_s > 0 and done else "- runs/min"
    res = f" ({skipped} resumed)" if skipped else ""
    return f"{n} runs{res}, {failed} failed, {wall_s:.0f} s wall, {rate}"
