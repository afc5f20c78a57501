"""The check's flights: the lab's world flown with a student's nodes, in lockstep at full speed.

One flight is a `towerlink fly` run (tools.fly_launch.Launch: world, bridge --route-only, the
tower, the nodes as separate processes) with lockstep on and --speedup max, so its figures are
the same on a laptop and on a loaded grading machine. The tower flies the lab's three goals
(the house, a 30 m leg, a 10 m leg) in its own frame, at most GOAL_TIMEOUT sim seconds each,
and stops (no landing): the run ends when the tower does.

The scenario of a flight is the lab's, with world -> tower replaced by the static transform
the flight uses (the student's from fly.launch for checkpoint 1): the bridge publishes it as
static_transform_publisher would, and translates the drone's telemetry to the tower with it.
A node that exits ends its flight at once; everything started is always stopped.
"""
from __future__ import annotations

import json
import re
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from common.scenario import DEFAULT_SCENARIO, load_scenario

#: the lab's three goals, world [x, y] (m, NED): the house with the package, then a 30 m and a 10 m leg
LAB_GOALS_WORLD = ((-4.0, -2.0), (26.0, -2.0), (26.0, 8.0))
GOAL_TIMEOUT = 20.0         # sim s the tower waits for each goal
FLIGHT_TIMEOUT = 300.0      # wall s for a whole flight (a machine far too busy, or a hang)
SEED = 1


def lab_goals() -> tuple[list[tuple[float, float, float]], list[tuple[float, float, float]]]:
    """(world goals, the same in the tower frame), x y z NED m, at the lab's altitude."""
    sc = load_scenario()
    to_tower = sc.buffer().lookup_transform("tower", "world").transform
    world = [(x, y, -sc.altitude) for x, y in LAB_GOALS_WORLD]
    return world, [tuple(float(v) for v in to_tower.apply_point(p)) for p in world]


def goals_arg() -> str:
    from gcs.tower_mission import format_goals
    return format_goals(lab_goals()[1])


def write_scenario(static_args: str, path: Path) -> Path:
    """The lab's scenario with world -> tower given by `static_args` (static_transform_publisher's)."""
    text = Path(DEFAULT_SCENARIO).read_text()
    new = f"static_transforms = [\n    {json.dumps(static_args)},\n]"
    text, n = re.subn(r"(?ms)^static_transforms\s*=\s*\[.*?^\]", new, text)
    if n != 1:
        raise RuntimeError(f"{DEFAULT_SCENARIO}: no static_transforms list to replace")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@dataclass(frozen=True)
class Flight:
    """What one flight flies: follow frame, the world -> tower it uses, the node files."""
    name: str                   # cp1, cp2, cp3: the checkpoint it is for
    follow_frame: str           # drone | drone_yaw (passed to the nodes as --follow-frame)
    static: str                 # world -> tower, static_transform_publisher's args
    nodes: tuple[Path, ...]
    about: str                  # a sentence for the report


@dataclass
class FlightRun:
    flight: Flight
    dir: Path
    tower_rc: int | None = None
    failure: str | None = None      # why it ended other than by the tower finishing
    exited: dict[str, int] = field(default_factory=dict)    # node name -> exit status, for nodes that ended
    wall: float = 0.0
    sim: float = 0.0


def fly(f: Flight, run_dir: Path, timeout: float = FLIGHT_TIMEOUT, speedup: float = float("inf")) -> FlightRun:
    """Fly `f` in lockstep (at --speedup max unless told) into run_dir; never raises for what
    the nodes do. A flight that never got going for a reason of the machine's (no sim time passed
    and no node ended it: a port taken meanwhile by another program) is flown once more."""
    shutil.rmtree(run_dir, ignore_errors=True)       # a check run again starts from nothing
    res = _fly_once(f, run_dir, timeout, speedup)
    if res.sim <= 0 and res.failure and not res.exited:
        shutil.rmtree(run_dir, ignore_errors=True)
        res = _fly_once(f, run_dir, timeout, speedup)
    return res


def _fly_once(f: Flight, run_dir: Path, timeout: float, speedup: float) -> FlightRun:
    from tools.fly_launch import Launch
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    scenario = write_scenario(f.static, run_dir / "scenario.toml")
    res = FlightRun(f, run_dir)
    t0 = time.monotonic()
    launch = Launch(run_dir, scenario=str(scenario), speedup=speedup, lockstep=True, seed=SEED,
                    follow_frame=f.follow_frame, goals=goals_arg(), finish="none", goal_timeout=GOAL_TIMEOUT,
                    nodes=list(f.nodes))
    try:
        launch.start()
        res.tower_rc = launch.wait(timeout, progress=None)
        if res.tower_rc is None:
            res.failure = f"timed out after {timeout:g} s wall"
    except RuntimeError as exc:             # a node (or the world) exited
        res.failure = str(exc)
    except Exception as exc:  # noqa: BLE001 - a flight that cannot run is a finding, not a crash
        res.failure = f"{type(exc).__name__}: {exc}"
    finally:
        if launch.monitor is not None:
            res.sim = float(launch.monitor.snapshot().get("sim") or 0.0)
        launch.stop()
        for p in f.nodes:
            if res.failure and f"node-{p.stem} exited" in res.failure:
                res.exited[p.stem] = launch.processes.exited(f"node-{p.stem}")
        res.wall = time.monotonic() - t0
    return res
