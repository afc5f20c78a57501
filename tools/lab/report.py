"""The report card: one line per checkpoint (text), report.md, report.json and the track plots.

`card(report)` is what `towerlink lab check` prints; `write_report` writes the files into the
report folder and returns the report (the dict report.json holds). A plot that fails never
hides the report.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tools.lab.result import Checkpoint

def write_report(sub, results: dict[int, Checkpoint], evidence: dict, out: Path, *, wall: float,
                 plot: bool = True) -> dict[str, Any]:
    """report.json, report.md and tracks*.png into `out`; returns the report."""
    plots = _plots(evidence, out) if plot else {}
    rep = {"name": sub.name, "dir": str(sub.dir), "report_dir": str(out),
           "passed": all(c.passed for c in results.values()),
           "checkpoints": [c.to_json() for c in results.values()],
           "flights": {k: {"dir": str(e.run.dir), "about": e.run.flight.about, "sim_s": e.run.sim,
                           "wall_s": round(e.run.wall, 2), "failure": e.run.failure}
                       for k, e in evidence.items()},
           "plots": plots, "wall_s": round(wall, 2)}
    (out / "report.json").write_text(json.dumps(rep, indent=2, default=_plain))
    (out / "report.md").write_text(_markdown(rep, results))
    return rep


def _plain(o):
    try:
        return o.item()
    except AttributeError:
        return str(o)


def card(rep: dict[str, Any]) -> str:
    """The report card as text: a line per checkpoint, its hints and notes under it."""
    lines = [f"towerlink lab check: {rep['name']} ({rep['dir']})"]
    for c in rep["checkpoints"]:
        lines.append(f"  CP{c['number']}  {c['title']:<22} {c['verdict']:<4}  {c['measured']}")
        lines += [f"        hint: {h['where']}" for h in c["hints"]]
        lines += [f"        note: {n}" for n in c["notes"]]
    n_ok = sum(c["passed"] for c in rep["checkpoints"])
    lines.append(f"  {n_ok}/{len(rep['checkpoints'])} checkpoints pass; report {rep['report_dir']}/report.md "
                 f"({rep['wall_s']:.1f} s)")
    return "\n".join(lines)


def class_table(reps: list[dict[str, Any]]) -> str:
    """One row per student: each checkpoint's verdict, and the count."""
    nums = sorted({c["number"] for r in reps for c in r["checkpoints"]})
    head = f"{'student':<24} " + " ".join(f"CP{n:<4}" for n in nums) + "  passed"
    rows = [head, "-" * len(head)]
    for r in sorted(reps, key=lambda r: r["name"]):
        by = {c["number"]: c["verdict"] for c in r["checkpoints"]}
        ok = sum(c["passed"] for c in r["checkpoints"])
        rows.append(f"{r['name']:<24} " + " ".join(f"{by.get(n, '-'):<6}" for n in nums)
                    + f"  {ok}/{len(r['checkpoints'])}" + (f"  ({r['error']})" if r.get("error") else ""))
    return "\n".join(rows)


def class_markdown(reps: list[dict[str, Any]]) -> str:
    """class.md: the table, then each student's failing checkpoints with their first hint or note."""
    md = ["# Lab check: the class", "", "```", class_table(reps), "```", ""]
    for r in sorted(reps, key=lambda r: r["name"]):
        bad = [c for c in r["checkpoints"] if not c["passed"]]
        if not bad:
            continue
        md += [f"## {r['name']}", "", f"Report: `{r['report_dir']}/report.md`", ""]
        for c in bad:
            why = c["hints"][0]["where"] if c["hints"] else (c["notes"][0] if c["notes"] else "")
            md.append(f"- CP{c['number']} {c['measured']}" + (f": {why}" if why else ""))
        md.append("")
    return "\n".join(md)


def _markdown(rep: dict[str, Any], results: dict[int, Checkpoint]) -> str:
    md = [f"# Lab check: {rep['name']}", "", f"Folder `{rep['dir']}`, checked in {rep['wall_s']:.1f} s.", "",
          "| checkpoint | verdict | measured |", "|---|---|---|"]
    md += [f"| CP{c.number} {c.title} | {c.verdict} | {c.measured} |" for c in results.values()]
    for c in results.values():
        md += ["", f"## Checkpoint {c.number}: {c.title} ({c.verdict})", "", c.measured, ""]
        md += [f"- **hint** {h}" for h in c.hints] + [f"- note: {n}" for n in c.notes]
        if c.number == 0 and c.details:
            md += ["", "Your static transform, both ways, as tf_echo prints it:", "", c.details]
        elif c.details:
            md += ["", c.details]
        flight = c.figures.get("flight")
        if flight and flight in rep["flights"]:
            f = rep["flights"][flight]
            md += ["", f"Flight `{flight}` ({f['sim_s']:.1f} s sim, {f['wall_s']:.1f} s wall): {f['about']}."]
            if flight in rep["plots"]:
                md += ["", f"![tracks]({rep['plots'][flight]})"]
    md += ["", "Look at a flight's frames yourself: `towerlink view-frames --tlog RUN/bridge.tlog -o frames.png`, "
           "`towerlink tf-echo --tlog RUN/bridge.tlog world drone` (RUN: a folder under runs/)."]
    return "\n".join(md) + "\n"


def _plots(evidence: dict, out: Path) -> dict[str, str]:
    """tracks.png for the first flight, tracks-<flight>.png for the others (name -> file)."""
    from common.scenario import load_scenario
    from tools.lab.flights import lab_goals
    from tools.plot_tracks import plot
    done: dict[str, str] = {}
    seen: dict[int, str] = {}
    sc = load_scenario()
    buf = sc.buffer()
    tower = buf.lookup_transform("world", "tower").transform.translation
    for k, ev in evidence.items():
        if id(ev) in seen:
            done[k] = seen[id(ev)]
            continue
        name = "tracks.png" if not done else f"tracks-{k}.png"
        goals = [(g, bool(c is not None and c <= 0.75)) for g, c in
                 ((g, ev.closest(g)) for g in lab_goals()[0])]
        try:
            plot(ev.data, out / name, goals=goals, tower=tower, buf=buf,
                 title=f"{k}: {ev.run.flight.about}")
        except Exception:  # noqa: BLE001 - a plot must not hide the report
            continue
        done[k] = seen[id(ev)] = name
    return done
