"""What `towerlink fly` writes into the run folder besides the tlogs and the logs.

meta.json (how the run was made, written at the start), then after the run: faults.json (when
each of the scenario's faults took effect and was cleared, as the link proxy applied them),
summary.json and summary.txt (the scores), tracks.png, frames.pdf / frames.png (the frame tree,
tools.fly_drawings), run.mcap. A drawing or a recording that fails never hides the summary: it is
left out. After the flight the recording (a forked child), the drawings (a forked child and its
sub-helper) and the scoring run side by side; with one CPU all of it is done here, one after the
other, from one read of bridge.tlog.
"""
from __future__ import annotations

import json
import math
import shlex
from pathlib import Path

from common.mavlink.lockstep import speedup_text
from common.mavlink.signing import masked_argv
from tools.fly_child import ForkedHelper
from tools.fly_drawings import Drawings
from tools.fly_plan import FlyPlan
from tools.fly_recorder import Recorder


def write_meta(plan: FlyPlan) -> None:
    """meta.json: the options, the ports and every command line (the signing key masked)."""
    meta = {"scenario": plan.scenario, "speedup": speedup_text(plan.speedup), "lockstep": plan.lockstep,
            "seed": plan.seed, "signed": bool(plan.signing_key),
            "follow_frame": plan.follow_frame, "goals": plan.goals, "tower_loss": plan.tower_loss,
            "tower_link": _link(plan), "faults": [f.describe() for f in plan.sc.faults],
            "follow_with": plan.follow_with, "ardupilot_follower": plan.ap_follower,
            "ports": plan.ports, "world_host": plan.world.describe() if plan.world else None,
            "commands": {k: shlex.join(masked_argv(v)) for k, v in plan.commands().items()}}
    (plan.dir / "meta.json").write_text(json.dumps(meta, indent=2))


def _link(plan: FlyPlan) -> dict | None:
    """The tower link's own settings per direction (None: a perfect link)."""
    base = plan.timeline.base
    return {d: s.as_dict() for d, s in base.items()} if any(s.active for s in base.values()) else None


def write_summary(plan: FlyPlan, tower_rc: int | None, *, bridge_restarts: int = 0,
                  proxy: dict | None = None, achieved_speedup: float | None = None,
                  applied: list[dict] | None = None, drawings: Drawings | None = None,
                  recorder: Recorder | None = None, fork: bool | None = None) -> dict:
    """Score the run, draw it, record it; returns the summary dict (its text under "text").

    `proxy`: the link proxy's frame counts ({"passed", "dropped", "overflow", "duplicated"},
    each per direction); `applied`: when each fault took effect and was cleared (written to
    faults.json); `achieved_speedup`: sim s per wall s (None if the sim clock never moved);
    `drawings`: who draws tracks.png and the frame tree (default: this process, after the scoring);
    `recorder`: the child recording run.mcap since the run started (default: a child forked now,
    unless `fork` is False, or None and this process has one CPU: then written here)."""
    bridge = None
    own = recorder is None and Recorder.available() and (fork if fork is not None else ForkedHelper.cpus() >= 2)
    if recorder is None and drawings is None and not own:
        bridge = read_bridge(plan.dir)          # one CPU: read once, for run.mcap, the scores and the frames
    if own:
        recorder = Recorder(plan.dir)           # run.mcap on the other core while this one scores
        recorder.start()
    try:
        if recorder is not None:
            recorder.flight_over()              # it reads the rest and writes run.mcap meanwhile
        else:                                   # no fork here: written now
            write_run_mcap_quietly(plan.dir, bridge)
        drawings = drawings or Drawings(plan.dir, plan.scenario, bridge)
        drawings.flight_over()                  # a worker draws the frame tree meanwhile
        s, text = _score(plan, tower_rc, bridge_restarts, proxy, achieved_speedup, applied, drawings, bridge)
        drawings.wait()
        if recorder is not None:
            recorder.wait()
    finally:
        if own:
            recorder.close()                    # stopped and reaped, also when the scoring failed
    files = sorted(p.name for p in plan.dir.iterdir())
    text += f"\nrun folder {plan.dir}: {' '.join(files)}"
    (plan.dir / "summary.txt").write_text(text + "\n")
    s["text"] = text
    return s


def _score(plan: FlyPlan, tower_rc: int | None, bridge_restarts: int, proxy: dict | None,
           achieved_speedup: float | None, applied: list[dict] | None, drawings: Drawings,
           bridge: list | None = None) -> tuple[dict, str]:
    """faults.json and summary.json written; (the summary dict, its text). The run's data are
    handed to `drawings` as soon as they are read, before the scoring (`bridge`: bridge.tlog's
    messages, already read by read_bridge)."""
    from tools.run_summary import format_summary, summarize
    if plan.sc.faults or applied:
        (plan.dir / "faults.json").write_text(json.dumps(
            {"faults": [f.as_dict() for f in plan.sc.faults], "applied": applied or []}, indent=2))
    tj = plan.dir / "tower.json"
    tower = json.loads(tj.read_text()) if tj.exists() else {"ok": False, "goals": [],
                                                            "error": "the tower wrote no result"}
    meta = {"seed": plan.seed, "speedup": plan.speedup if math.isfinite(plan.speedup) else "max",
            "lockstep": plan.lockstep, "signed": bool(plan.signing_key),
            "tower_exit": tower_rc, "follow_frame": plan.followed_frame,
            "run_dir": str(plan.dir), "bridge_restarts": bridge_restarts,
            "tower_loss": plan.tower_loss}
    if _link(plan) is not None:
        meta["tower_link"] = _link(plan)
    if plan.nodes:
        meta["nodes"] = [p.stem for p in plan.nodes]
    if proxy is not None:
        meta["proxy"] = proxy
    if achieved_speedup is not None:
        meta["achieved_speedup"] = achieved_speedup
    from tools.run_data import load_run
    data = load_run(plan.dir, bridge)   # read once: the summary and the plot share it
    drawings.tracks(data)               # tracks.png needs nothing more: drawn while this one scores
    if plan.family:
        from tools.family_summary import format_family_summary, summarize_family
        s = summarize_family(plan.dir, tower=tower, scenario_path=plan.scenario, meta=meta, data=data)
        s["faults"] = _family_faults(plan, tower, data)
    else:
        s = summarize(plan.dir, tower=tower, scenario_path=plan.scenario, meta=meta, data=data)
    s["ok"] = bool(s["ok"]) and tower_rc == 0
    (plan.dir / "summary.json").write_text(json.dumps(s, indent=2, default=_json_default))
    if plan.family:
        from tools.fault_summary import format_faults
        text = "\n".join([format_family_summary(s), *format_faults(s["faults"])])
    else:
        text = format_summary(s)
    return s, text


def tower_end_sim(run_dir: Path) -> float | None:
    """The sim time (s) the tower's run ended at, from RUN/tower.json: a lab run's end_sim, a
    family's latest drone's; None without a result that says."""
    try:
        tower = json.loads((Path(run_dir) / "tower.json").read_text())
    except (OSError, ValueError):
        return None
    ends = [tower.get("end_sim"), *(d.get("end_sim") for d in tower.get("drones", []) if isinstance(d, dict))]
    ends = [float(e) for e in ends if isinstance(e, (int, float))]
    return max(ends) if ends else None


def _family_faults(plan: FlyPlan, tower: dict, data) -> dict:
    """The fault section of a family run (its tower result holds a goal list per drone)."""
    from tools.fault_summary import fault_section
    from tools.run_summary import read_applied
    goals = [g for d in tower.get("drones", []) for g in d.get("goals", [])]
    names = {sysid: name for name, sysid, _kind in plan.sc.vehicles}
    ends = [d["end_sim"] for d in tower.get("drones", []) if d.get("end_sim") is not None]
    return fault_section(plan.sc.faults, read_applied(plan.dir), data, names, goals, end=max(ends) if ends else None)


def read_bridge(run_dir: Path) -> list | None:
    """bridge.tlog's messages, decoded as far as run.mcap, the scores and the frame tree need them
    (tools.tlog_stamped); None without a readable bridge.tlog (each then reads for itself)."""
    try:
        from tools.run_data import BRIDGE_OWN
        from tools.run_mcap import scene_messages
        return list(scene_messages(run_dir / "bridge.tlog", also=BRIDGE_OWN))
    except Exception:  # noqa: BLE001 - missing or unreadable: each reader then tries for itself
        return None


def write_run_mcap_quietly(run_dir: Path, bridge: list | None = None) -> None:
    """run_dir/run.mcap from the finished tlogs (`bridge`: bridge.tlog's messages, already read),
    here and now; left out if it fails."""
    try:
        from tools.run_mcap import write_run_mcap
        write_run_mcap(run_dir, bridge)
    except Exception:  # noqa: BLE001 - the recording must not hide the summary
        pass


def _json_default(o):
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
    except ImportError:  # pragma: no cover
        pass
    return str(o)
