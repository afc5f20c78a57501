"""Sweep a mission over seeds, wind, tower-link loss, follow frame, speed limits, any scenario value.

Each run is `towerlink fly --lockstep --speedup max --seed S ...` (the same figures at any speed
and load) in its own processes and free ports, as a Ray task (num_cpus=1): local by default
with no set-up, on a cluster with --address. Needs the sweep extra: pip install 'towerlink[sweep]'.

  towerlink sweep --seeds 1-20                                   # the lab mission, 20 seeds
  towerlink sweep --set follow_frame=drone,drone_yaw --set tower_loss=0,0.2 --seeds 1-3
  towerlink sweep --grid examples/sweep/frames_loss.toml --out sweeps/frames
  towerlink sweep --set WPNAV_SPEED=300,500,800 --set wind=0,8 --seeds 1-5
  towerlink sweep --set mission.altitude=6,12 --address auto     # on a running Ray cluster
  towerlink sweep --grid examples/sweep/faults.toml              # mission and failsafes by fault
  towerlink sweep --resume --out sweeps/frames                   # finish an interrupted sweep

Factors (--set NAME=V1,V2,... adds a grid factor; a sweep file gives [grid] and [[runs]]):
  seed, wind (SPEED or [SPEED,DIR,TURB]), tower_loss (0..1), follow_frame (drone|drone_yaw),
  finish (land|rtl|none), a tower-link setting (tower_link.latency=0,0.2,0.5; tower_link.up.loss),
  any vehicle parameter by name (WPNAV_SPEED=300: cm/s), any scenario value by dotted key
  (mission.altitude=12; a fault's: faults.0.t=10,20). The sweep file format: tools/sweep_grid.py.
  Everything is checked before Ray starts.

Output (--out DIR, default sweeps/<timestamp>):
  DIR/runs/<run-id>/     each run's fly folder (summary.json, tlogs, tracks.png) and row.json
  DIR/results.csv        one row per run: run_id, the factors, pass, reason, wall_s, the key
  DIR/results.parquet    figures, then every number of summary.json flattened (dotted names)
  DIR/sweep.png          follow error, wobble, reach-time ratios and failure rate by factor
  DIR/effects.txt        each factor's effect (seeds are repeats): per level mean ± std of the
                         follow error, wobble and reach-time ratio (and the delay from a fault to
                         its first failsafe, when there were any), and the pass rate (also printed)
  DIR/sweep.json         the plan: scenario, options, every run's id and factors

Progress: on a terminal a bar (done/total, failed, flying, elapsed, ETA) with each finished
run's line above it; elsewhere (CI, a log file) one plain line per finished run.

Run ids are hashes of the scenario and the factors: rerunning the same sweep into the same
DIR (or --resume) does not redo finished runs. A run that fails or times out is a row with
pass False and its reason. Ctrl-C stops the running flights cleanly and writes the table of
the finished ones. Exit status 0 when every run has a row (failed missions are results), 2
for a bad plan or a missing Ray, 130 when interrupted.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
import os
import signal
import socket
import sys
import time
import tomllib
from pathlib import Path
from typing import Any, Callable

from tools.sweep_grid import Plan, Run, SweepError

INSTALL_HINT = ("towerlink sweep needs Ray, pyarrow and tqdm, the sweep extra: "
                "pip install 'towerlink[sweep]' (in this checkout: pip install -e '.[sweep]', or make sweep)")
PROJECT_ROOT = str(Path(__file__).resolve().parent.parent)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", default=None,
                        help="scenario TOML or a shipped one by name (default: the sweep file's, else the lab's)")
    parser.add_argument("--grid", metavar="FILE.toml", help="sweep file: [grid] factor = [values], [[runs]], "
                        "seeds, timeout (see examples/sweep/)")
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="FACTOR=V1,V2,...",
                        help="sweep a factor over these values (repeatable; replaces the file's)")
    parser.add_argument("--seeds", metavar="SPEC", help="the seeds, e.g. 1-20 or 1,3,5 (default 1)")
    parser.add_argument("--out", metavar="DIR", help="sweep folder (default sweeps/<timestamp>)")
    parser.add_argument("--address", metavar="HOST:PORT|auto|ray://HOST:10001",
                        help="a running Ray cluster to run on (default: a local Ray started for this sweep): "
                             "its head's GCS address as `ray start --head` prints it, auto (the cluster on this "
                             "machine), or ray:// through Ray Client. Every node needs towerlink installed; DIR "
                             "is best on a shared file system (else each run's folder stays on its node; "
                             "summary.json and row.json come back here). A cluster with token authentication "
                             "(Ray's RAY_AUTH_MODE=token) needs the same in this shell")
    parser.add_argument("--parallel", type=int, default=None, metavar="N",
                        help="runs at once (default: the CPUs Ray has; each run is one CPU)")
    parser.add_argument("--speedup", choices=("max",), default="max",
                        help="every run flies in lockstep at --speedup max (the only choice: the figures "
                             "do not depend on the speed)")
    parser.add_argument("--timeout", type=float, default=None, metavar="S",
                        help="wall seconds per run before it counts as failed (default 600)")
    parser.add_argument("--goal-timeout", type=float, default=None, metavar="S",
                        help="wall seconds per goal (fly --goal-timeout)")
    parser.add_argument("--resume", action="store_true",
                        help="continue the sweep in --out DIR from its sweep.json (no grid needed); "
                             "finished runs are kept")
    parser.add_argument("--dry-run", action="store_true", help="check the plan and list the runs; start nothing")


# ----------------------------------------------------------------------------- the plan


def build(args: argparse.Namespace) -> tuple[Path | None, dict, list[Run], Plan]:
    """Scenario path, its data, the runs and the plan; SweepError / ScenarioError when bad."""
    from common.scenario import ScenarioError, _build, scenario_path
    from tools import sweep_grid as g
    if args.resume:
        if not args.out:
            raise SweepError("--resume continues a sweep: give its folder with --out DIR")
        saved = _read_json(Path(args.out) / "sweep.json")
        if saved is None:
            raise SweepError(f"--resume: {Path(args.out) / 'sweep.json'} is missing or damaged")
        plan = Plan(grid=saved["plan"]["grid"], runs=saved["plan"]["runs"], scenario=saved["plan"]["scenario"],
                    timeout=saved["plan"]["timeout"], goal_timeout=saved["plan"]["goal_timeout"])
    elif args.grid:
        try:
            text = Path(args.grid).read_text()
        except OSError as exc:
            raise SweepError(f"--grid {args.grid}: {exc.strerror or exc}") from None
        plan = g.plan_from_toml(text, where=args.grid)
        beside = Path(args.grid).parent / plan.scenario if plan.scenario else None
        if beside is not None and not Path(plan.scenario).is_absolute() and beside.is_file():
            plan.scenario = str(beside)         # a scenario file next to the sweep file
    else:
        plan = Plan()
    g.apply_cli(plan, args.sets, args.seeds)
    if args.scenario:
        plan.scenario = args.scenario
    if args.timeout is not None:
        plan.timeout = args.timeout
    if args.goal_timeout is not None:
        plan.goal_timeout = args.goal_timeout
    for key in ("timeout", "goal_timeout"):
        v = getattr(plan, key)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise SweepError(f"--{key.replace('_', '-')} must be > 0 seconds")
    path = scenario_path(plan.scenario).resolve() if plan.scenario else scenario_path(None).resolve()
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None
    _build(data, path)          # the scenario itself is sound
    runs = g.expand(plan, data, g.scenario_digest(path), validate_scenario=lambda d: _build(d, path))
    if not runs:
        raise SweepError("the plan has no runs")
    return path, data, runs, plan


def _read_json(p: Path) -> dict | None:
    from tools.sweep_run import read_json
    return read_json(p)


def run_specs(runs: list[Run], scenario: Path, data: dict, plan: Plan, out: Path) -> list[dict[str, Any]]:
    """What each Ray task needs: fly's arguments, the run folder, its scenario copy."""
    from tools import sweep_grid as g
    specs = []
    timeout = plan.timeout or 600.0
    for r in runs:
        run_dir = (out / "runs" / r.run_id).resolve()
        copy = g.scenario_copy(data, r.factors)
        flies = str(run_dir / "scenario.toml") if copy is not None else str(scenario)
        specs.append({"run_id": r.run_id, "factors": r.factors, "run_dir": str(run_dir),
                      "argv": g.fly_args(r.factors, flies, str(run_dir), timeout=timeout,
                                         goal_timeout=plan.goal_timeout),
                      "scenario_toml": g.to_toml(copy) if copy is not None else None,
                      "timeout": timeout, "root": PROJECT_ROOT})
    return specs


# ----------------------------------------------------------------------------- Ray


def _check_listening(address: str, timeout: float = 5.0) -> None:
    """SweepError unless something accepts TCP at a HOST:PORT (or ray://HOST:PORT) address:
    ray.init retries an address where nothing listens for minutes, saying little."""
    hostport = address.removeprefix("ray://")
    host, sep, port = hostport.rpartition(":")
    if not sep or not port.isdigit():
        return                  # auto, local: Ray finds the cluster itself
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as exc:
        raise SweepError(f"cannot join the Ray cluster at {address}: nothing accepts a connection there "
                         f"({exc.strerror or exc}); start one with `ray start --head` and give the address "
                         "it prints") from None


def start_ray(address: str | None, parallel: int | None):
    """ray.init, quiet: no dashboard, a bounded object store, no usage stats, worker logs in
    Ray's own folder (each run keeps its own logs in its folder)."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    os.environ.setdefault("RAY_DEDUP_LOGS", "0")
    # local workers inherit the driver's environment: they import this checkout's tools
    os.environ["PYTHONPATH"] = os.pathsep.join(
        [PROJECT_ROOT, *[p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p and p != PROJECT_ROOT]])
    import ray
    quiet: dict[str, Any] = dict(log_to_driver=False, logging_level=logging.ERROR)
    if address:     # a cluster (ray://HOST:10001 through Ray Client, or auto): it has its own settings
        _check_listening(address)
        try:
            ray.init(address=address, **quiet)
        except (ConnectionError, ray.exceptions.RayError, ValueError) as exc:
            lines = [ln for ln in str(exc).strip().splitlines() if ln.strip()]
            # a token refused says so only in the cause ('Failed to connect' on top): say what to set
            token = "auth" in f"{exc} {exc.__cause__ or ''}".lower()
            raise SweepError(f"cannot join the Ray cluster at {address}: {type(exc).__name__}: "
                             f"{lines[0] if lines else ''}"
                             + ("; it wants its token: set RAY_AUTH_MODE=token and give the token "
                                "(RAY_AUTH_TOKEN, or the file ~/.ray/auth_token)" if token else "")) from None
    else:
        ray.init(num_cpus=parallel or os.cpu_count() or 1, object_store_memory=128 * 1024 * 1024,
                 include_dashboard=False, **quiet)
    return ray


class Interrupt:
    """SIGINT / SIGTERM handler: remembers the request and raises KeyboardInterrupt. Ray's own
    code may swallow the KeyboardInterrupt (during ray.init), so the loop also checks `hit`."""

    def __init__(self) -> None:
        self.hit = False

    def __call__(self, signum, frame) -> None:
        self.hit = True
        raise KeyboardInterrupt

    def check(self) -> None:
        if self.hit:
            raise KeyboardInterrupt


def execute(ray, specs: list[dict], parallel: int, on_row, stop: Interrupt | None = None,
            on_flying: Callable[[int], None] | None = None, say: Callable[[str], None] | None = None) -> bool:
    """Run the specs as Ray tasks, at most `parallel` at once; on_row(spec, row, summary) as each
    ends, on_flying(n) with the runs in flight at least once a second, say(line) for a message
    (default: print it on a line of its own; the progress bar writes it above itself). Returns False when
    interrupted (Ctrl-C): running flights are cancelled and stopped."""
    from tools.sweep_run import run_one
    task = ray.remote(num_cpus=1, max_retries=0)(run_one)
    todo = list(specs)
    pending: dict[Any, dict] = {}
    stop = stop or Interrupt()
    try:
        while todo or pending:
            stop.check()
            while todo and len(pending) < parallel:
                spec = todo.pop(0)
                pending[task.remote(spec)] = spec
            if on_flying is not None:       # each second at least: the bar's clock moves on
                on_flying(len(pending))
            done, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
            for ref in done:
                spec = pending.pop(ref)
                try:
                    res = ray.get(ref)
                    row, summary = res["row"], res["summary"]
                except Exception as exc:  # noqa: BLE001 - a lost worker / task is a failed row
                    from tools.sweep_table import make_row
                    msg = str(exc).strip().splitlines()
                    row = make_row(spec["run_id"], spec["factors"], None, wall_s=None,
                                   reason=f"Ray task failed: {type(exc).__name__}: {msg[-1] if msg else ''}")
                    summary = None
                on_row(spec, row, summary)
        return True
    except KeyboardInterrupt:
        msg = f"[sweep] interrupted: stopping {len(pending)} running flight(s)..."
        say(msg) if say is not None else print("\n" + msg, flush=True)
        for ref in pending:
            try:
                ray.cancel(ref)         # KeyboardInterrupt in the task: it stops its fly (SIGINT)
            except Exception:  # noqa: BLE001
                pass
        deadline = time.monotonic() + 60.0
        left = list(pending)
        while left and time.monotonic() < deadline:
            try:
                _done, left = ray.wait(left, num_returns=len(left), timeout=1.0)
            except KeyboardInterrupt:
                break
        if on_flying is not None:
            on_flying(len(left))        # the bar's last state: the flights still not stopped (none, normally)
        return False


# ----------------------------------------------------------------------------- output


def write_outputs(out: Path, rows: list[dict], runs: list[Run], varying: list[str]) -> list[str]:
    """results.csv, results.parquet, sweep.png, effects.txt (each written atomically)."""
    import csv
    import io
    from tools import sweep_table as t
    from tools.sweep_run import write_atomic
    factor_names = list(dict.fromkeys(k for r in runs for k in r.factors))
    cols = t.columns(rows, factor_names)
    norm = t.normalise(rows, cols)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in norm:
        w.writerow({k: ("" if v is None else v) for k, v in r.items()})
    write_atomic(out / "results.csv", buf.getvalue())
    files = ["results.csv"]
    import pyarrow as pa
    import pyarrow.parquet as pq
    table = pa.Table.from_pylist(norm)
    tmp = out / ".results.parquet.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, out / "results.parquet")
    files.append("results.parquet")
    # seeds are repeats, not a factor: the effects of the others, or all runs together
    eff_factors = [f for f in varying if f != "seed"] or ["all"]
    rows = [dict(r, all="all runs") for r in rows] if eff_factors == ["all"] else rows
    figs = t.effect_figures(rows)
    text = t.format_effects(t.effects(rows, eff_factors, figs), figs)
    write_atomic(out / "effects.txt", text + "\n")
    files.append("effects.txt")
    try:
        from tools.sweep_plots import plot_sweep
        plot_sweep(rows, eff_factors, out / "sweep.png")
        files.append("sweep.png")
    except Exception as exc:  # noqa: BLE001 - a plot failure must not hide the table
        print(f"[sweep] plot failed: {exc}", file=sys.stderr)
    return files


def _fly_all(args, todo: list[dict], rows: dict[str, dict], total: int, stop: Interrupt) -> bool:
    """Start Ray, fly the runs, shut Ray down; False when interrupted."""
    from tools import sweep_grid as g
    from tools.sweep_progress import Progress
    from tools.sweep_run import write_atomic
    try:
        ray = start_ray(args.address, args.parallel)
    except KeyboardInterrupt:
        stop.hit = True
        ray = None
    except SweepError as exc:
        print(f"towerlink sweep: {exc}", file=sys.stderr, flush=True)
        raise
    progress = None
    try:
        if ray is None or stop.hit:
            print("\n[sweep] interrupted while Ray was starting", flush=True)
            return False
        cpus = int(ray.available_resources().get("CPU", 1)) or 1
        parallel = min(args.parallel or cpus, len(todo))
        print(f"towerlink sweep: Ray {ray.__version__} "
              f"{'at ' + args.address if args.address else 'local'}, {parallel} run(s) at once", flush=True)
        progress = Progress(total, done=len(rows), failed=sum(not r.get("pass") for r in rows.values()))

        def on_row(spec, row, summary):
            rows[spec["run_id"]] = row
            if summary is not None and not (Path(spec["run_dir"]) / "summary.json").exists():
                # a cluster worker's folder is on its own host: keep the summary and row here
                Path(spec["run_dir"]).mkdir(parents=True, exist_ok=True)
                write_atomic(Path(spec["run_dir"]) / "summary.json", json.dumps(summary, indent=1, default=str))
                write_atomic(Path(spec["run_dir"]) / "row.json", json.dumps(row, indent=1, default=str))
            progress.finished(f"{spec['run_id']} {g.format_factors(spec['factors'])}", bool(row.get("pass")),
                              row.get("reason"), row.get("wall_s"))

        return execute(ray, todo, parallel, on_row, stop, on_flying=progress.started, say=progress.note)
    finally:
        if progress is not None:
            progress.close()
        if ray is not None:
            try:
                ray.shutdown()
            except KeyboardInterrupt:
                pass


def run(args: argparse.Namespace) -> int:
    from common.scenario import ScenarioError
    from tools import sweep_grid as g
    from tools import sweep_table as t
    from tools.sweep_run import finished, write_atomic
    try:
        scenario, data, runs, plan = build(args)
        if args.parallel is not None and args.parallel < 1:
            raise SweepError("--parallel must be >= 1")
    except (SweepError, ScenarioError) as exc:
        print(f"towerlink sweep: {exc}", file=sys.stderr)
        return 2
    varying = g.varying_factors(runs)
    out = Path(args.out) if args.out else Path("sweeps") / time.strftime("%Y%m%d-%H%M%S")
    if args.dry_run:
        for r in runs:
            print(f"{r.run_id}  {r.label()}")
        print(f"{len(runs)} runs of {scenario.name}; varying: {', '.join(varying) or 'nothing'}")
        return 0
    try:
        import pyarrow  # noqa: F401
        import ray  # noqa: F401
        from tools.sweep_progress import require_bar_library
        require_bar_library()
    except ImportError:
        print(f"towerlink sweep: {INSTALL_HINT}", file=sys.stderr)
        return 2
    (out / "runs").mkdir(parents=True, exist_ok=True)
    specs = run_specs(runs, scenario, data, plan, out)
    write_atomic(out / "sweep.json", json.dumps({
        "scenario": str(scenario),
        "plan": {"grid": plan.grid, "runs": plan.runs, "scenario": plan.scenario, "timeout": plan.timeout,
                 "goal_timeout": plan.goal_timeout},
        "runs": [{"run_id": r.run_id, "factors": r.factors} for r in runs]}, indent=1, default=str))
    rows: dict[str, dict] = {}
    for spec in specs:          # finished earlier: re-read (a newer table code re-flattens)
        row = finished(Path(spec["run_dir"]))
        if row is not None:
            summary = _read_json(Path(spec["run_dir"]) / "summary.json")
            rows[spec["run_id"]] = t.make_row(spec["run_id"], spec["factors"], summary, wall_s=row.get("wall_s"),
                                              reason=row.get("reason") or None) if summary else row
    resumed = len(rows)
    todo = [s for s in specs if s["run_id"] not in rows]
    total = len(specs)
    print(f"towerlink sweep: {total} runs of {scenario.name} ({len(todo)} to fly, {resumed} already finished) "
          f"varying {', '.join(varying) or 'nothing'}; folder {out}", flush=True)
    t0 = time.monotonic()
    ok = True
    stop = Interrupt()
    old_handlers = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        ok = _fly_all(args, todo, rows, total, stop) if todo else True
    except SweepError:          # said already (the cluster could not be joined): nothing flown
        return 2
    finally:
        for sig, h in old_handlers.items():
            signal.signal(sig, h)
    wall = time.monotonic() - t0
    ordered = [rows[s["run_id"]] for s in specs if s["run_id"] in rows]
    if ordered:
        files = write_outputs(out, ordered, [r for r in runs if r.run_id in rows], varying)
        print("\n" + (out / "effects.txt").read_text().rstrip())
        print(f"\n{out}: {' '.join(files)}")
    print(f"towerlink sweep: {t.summary_line(ordered, wall, skipped=resumed)}"
          f"{'' if ok else f'; interrupted, {total - len(ordered)} run(s) left (rerun with --resume --out {out})'}",
          flush=True)
    return 0 if ok else 130
