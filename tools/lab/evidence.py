"""What a flight shows, read back from its run folder: the figures the checkpoints are judged on.

From the tlogs (tools.run_data, one pass over each): the drone's and the rover's truth, the goals
each vehicle was given (their POSITION_TARGET_LOCAL_NED echo: what the nodes sent, as the
vehicle took it), the frames the nodes broadcast (the bridge's stream), the drone's own clock;
from tools.run_summary the follow error and the wobble; from the nodes' logs a traceback, if
one ended that way. Pure data work on files: no sockets.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from common.scenario import DEFAULT_SCENARIO
from tools.lab.flights import FlightRun
from tools.run_data import DRONE, ROVER, RunData, load_messages, read_tlog
from tools.run_figures import world_transforms

TAKEOFF_MASK = 2552         # the drone's target while it climbs (NAV_TAKEOFF), not a goal


@dataclass(frozen=True)
class Crash:
    """A node's traceback: the deepest line of the student's file, and the exception."""
    file: str
    line: int | None
    error: str
    stopped: bool = True        # the node ended; False: a callback raised and the node went on


def _target_rows(msgs, sink: list):
    """Pass messages through, keeping (sysid, t, x, y, z, type_mask) of each POSITION_TARGET_LOCAL_NED."""
    for m in msgs:
        if m.get_type() == "POSITION_TARGET_LOCAL_NED":
            sink.append((m.get_srcSystem(), m.time_boot_ms / 1000.0, m.x, m.y, m.z, m.type_mask))
        yield m


CALLBACK_FAILED = re.compile(r"callback (\S+) failed: (.*?)(?: at (\S+) line (\d+))?$", re.M)


def crash_in(log: str, node_file: str) -> Crash | None:
    """The traceback in a node's log (the last one), pinned to the student's file when it is in it;
    else the first callback that failed (the node goes on, but that callback never does its job)."""
    i = log.rfind("Traceback (most recent call last):")
    if i < 0:
        m = CALLBACK_FAILED.search(log)
        if m is None:
            return None
        return Crash(m.group(3) or node_file, int(m.group(4)) if m.group(4) else None,
                     f"{m.group(2)} in the callback {m.group(1)}", stopped=False)
    tb = log[i:].splitlines()
    frames = [(m.group(1), int(m.group(2))) for m in (re.match(r'\s*File "(.*)", line (\d+)', ln) for ln in tb) if m]
    error = next((ln.strip() for ln in reversed(tb) if ln.strip() and not ln.startswith((" ", "\t"))), "")
    mine = [f for f in frames if Path(f[0]).name == node_file]
    file, line = mine[-1] if mine else (frames[-1] if frames else (node_file, None))
    return Crash(Path(file).name, line, error)


@dataclass
class Evidence:
    run: FlightRun
    data: RunData
    tower: dict
    summary: dict
    targets: dict[int, np.ndarray] = field(default_factory=dict)   # sysid -> (n, 5): t, x, y, z (world), mask
    logs: dict[str, str] = field(default_factory=dict)            # node name -> its log

    @classmethod
    def read(cls, run: FlightRun) -> "Evidence":
        from tools.run_summary import summarize
        d = run.dir
        data, rows = RunData(), []
        if (d / "vehicles.tlog").exists():
            load_messages(_target_rows(read_tlog(d / "vehicles.tlog"), rows), data)
        if (d / "bridge.tlog").exists():
            load_messages((m for m in read_tlog(d / "bridge.tlog") if m.get_type().startswith("TOWERLINK_")), data)
        tj = d / "tower.json"
        tower = json.loads(tj.read_text()) if tj.exists() else {"ok": False, "goals": []}
        summary = summarize(d, data=data, tower=tower, scenario_path=str(DEFAULT_SCENARIO))
        ev = cls(run, data, tower, summary)
        a = np.array(rows, float) if rows else np.zeros((0, 6))
        for sysid in (DRONE, ROVER):
            m = a[a[:, 0] == sysid][:, 1:] if len(a) else np.zeros((0, 5))
            if sysid == ROVER and len(m):
                m = m[np.hypot(m[:, 1], m[:, 2]) > 1e-6]     # (0, 0): no goal given yet
                off = data.statics.get(("world", "rover_origin"))
                if off is not None:
                    m[:, 1:4] += np.array(off[:3])          # the rover's local frame -> world
            ev.targets[sysid] = m
        for p in run.flight.nodes:
            log = d / f"node-{p.stem}.log"
            ev.logs[p.stem] = log.read_text(errors="replace") if log.exists() else ""
        return ev

    # -- what the checkpoints ask

    def crash(self, node: str) -> Crash | None:
        return crash_in(self.logs.get(node, ""), f"{node}.py")

    def drone_goals(self) -> np.ndarray:
        """The goals the drone was given after the tower's first (t, x, y, z), each kept once, in order."""
        t = self.targets.get(DRONE, np.zeros((0, 5)))
        first = next((g.get("sent_sim") for g in self.tower.get("goals", []) if g.get("sent_sim") is not None), None)
        if not len(t) or first is None:
            return np.zeros((0, 4))
        t = t[(t[:, 0] >= first) & (t[:, 4] != TAKEOFF_MASK)]
        out: list = []
        for row in t:
            if not out or np.hypot(*(row[1:3] - out[-1][1:3])) > 0.05:
                out.append(row[:4])
        return np.array(out) if out else np.zeros((0, 4))

    def closest(self, goal) -> float | None:
        """How near the drone's true position came to a world point (m, 3-D); None without truth."""
        tr = self.data.truth.get(DRONE)
        if tr is None or not len(tr):
            return None
        return float(np.min(np.linalg.norm(tr.xyz - np.asarray(goal, float), axis=1)))

    def frame(self, child: str) -> list[tuple[float, tuple]]:
        """Every world -> child transform the stream carried: (stamp s, (x, y, z, qx, qy, qz, qw))."""
        return world_transforms(self.data, child)

    def drone_clock(self) -> np.ndarray:
        est = self.data.estimate.get(DRONE)
        return est.t if est is not None else np.zeros(0)

    def rover_goals(self) -> np.ndarray:
        """The rover's goals as it took them: (t, x, y, z), world NED m."""
        t = self.targets.get(ROVER, np.zeros((0, 5)))
        return t[:, :4] if len(t) else np.zeros((0, 4))
