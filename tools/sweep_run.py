"""One run of a sweep: `towerlink fly` in its own processes, its row written atomically (no Ray here).

`run_one(spec)` is what a Ray task executes (tools/sweep.py wraps it in ray.remote); it never
raises for a failed mission, a crashed fly or a timeout: those are rows with pass False and a
reason. Only a cancellation (KeyboardInterrupt: Ctrl-C on the sweep, ray.cancel) propagates,
after fly and everything it started have been stopped.

A run folder is finished when its row.json (written last, atomically) and summary.json are
there; `finished(run_dir)` is how a rerun knows not to redo it.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from tools.procs import die_with_parent

ROW_FILE = "row.json"
GRACE_S = 60.0          # beyond fly's own --timeout: fly stops itself and summarises first


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write a file whole or not at all (a temporary beside it, then rename)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def read_json(path: Path) -> dict | None:
    """A JSON object from a file, or None when it is missing or damaged."""
    try:
        d = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return d if isinstance(d, dict) else None


def finished(run_dir: Path) -> dict | None:
    """The row of a finished run (row.json and summary.json complete), else None."""
    row = read_json(Path(run_dir) / ROW_FILE)
    if row is None or "pass" not in row:
        return None
    summary = read_json(Path(run_dir) / "summary.json")
    if summary is None or "ok" not in summary:
        # a run that never got as far as a summary (fly crashed or hung) has a row of its
        # own reason; keep it only when it says so
        return row if row.get("reason") and not row.get("pass") else None
    return row


def _fly_reason(log: Path, own_only: bool = False) -> str | None:
    """fly's own last word on a failure ('towerlink fly: timed out after 300 s wall; ...'); else
    (not `own_only`) the log's last line that says something."""
    try:
        lines = log.read_text(errors="replace").splitlines()
    except OSError:
        return None
    for line in reversed(lines):
        if line.startswith("towerlink fly: ") and "run folder" not in line and "(ports" not in line:
            return line[len("towerlink fly: "):].removesuffix("; all processes stopped")
    if own_only:
        return None
    # else the last line that says something: not fly's closing list of the run folder's files
    tail = [ln for ln in lines if ln.strip() and not ln.startswith("run folder ")][-1:]
    return tail[0][:200] if tail else None


def _descendants(pid: int) -> list[int]:
    """Every process below `pid` (Linux /proc): fly starts the world, the bridge and the tower in
    sessions of their own, so a signal to fly's group does not reach them."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            out.append(c)
            todo.append(c)
    return out


def _signal(pids: list[int], sig: int) -> None:
    for pid in pids:
        try:
            os.kill(pid, sig)
        except (ProcessLookupError, PermissionError):
            pass


def _stop(p: subprocess.Popen, grace: float = 20.0) -> None:
    """Stop fly as Ctrl-C does (it stops its processes and summarises); whatever it started and
    left behind is then stopped too (SIGTERM, then SIGKILL)."""
    below = _descendants(p.pid)
    if p.poll() is None:
        try:
            os.killpg(p.pid, signal.SIGINT)
        except (ProcessLookupError, PermissionError):
            pass
        try:
            p.wait(grace)
        except subprocess.TimeoutExpired:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            p.wait(10)
    left = [q for q in below if _alive(q)]
    _signal(left, signal.SIGTERM)
    deadline = time.monotonic() + 5.0
    while left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = [q for q in left if _alive(q)]
    _signal(left, signal.SIGKILL)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"     # a zombie has already stopped
    except (OSError, IndexError):
        return False


def run_one(spec: dict[str, Any]) -> dict[str, Any]:
    """Fly one run. spec: run_id, factors, run_dir, argv (fly's arguments), timeout (s),
    scenario_toml (the run's own scenario copy, or None), root (the project, for PYTHONPATH).
    Returns {"row": ..., "summary": ...}."""
    from tools.sweep_table import make_row
    run_dir = Path(spec["run_dir"])
    if run_dir.exists():            # an unfinished earlier attempt: start cleanly
        shutil.rmtree(run_dir, ignore_errors=True)
    run_dir.mkdir(parents=True, exist_ok=True)
    if spec.get("scenario_toml"):
        (run_dir / "scenario.toml").write_text(spec["scenario_toml"])
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    root = spec.get("root")
    if root and not Path(root, "tools", "cli.py").exists():
        root = None             # another host (a cluster node): its own installed towerlink
    if root:
        env["PYTHONPATH"] = os.pathsep.join([root, *[p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]])
    cmd = [sys.executable, "-m", "tools.cli", *spec["argv"]]
    log = run_dir / "fly.log"
    reason = None
    t0 = time.monotonic()
    with open(log, "w") as out:
        out.write(f"$ {' '.join(cmd)}\n")
        out.flush()
        p = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=root or None, env=env,
                             start_new_session=True, preexec_fn=die_with_parent())
        try:
            rc = p.wait(float(spec["timeout"]) + GRACE_S)
        except subprocess.TimeoutExpired:
            _stop(p)
            rc = p.returncode
            reason = f"timed out: fly did not end within {float(spec['timeout']) + GRACE_S:g} s wall"
        except BaseException:           # cancelled (KeyboardInterrupt from ray.cancel, Ctrl-C)
            _stop(p)
            raise
    wall = time.monotonic() - t0
    summary = read_json(run_dir / "summary.json")
    if reason is None and (summary is None or not summary.get("ok") or rc != 0):
        # with a summary, the row's own reason (the tower's error, the goals, the first failsafe)
        # unless fly itself said what went wrong
        said = _fly_reason(log, own_only=summary is not None)
        if summary is None:
            reason = f"fly exited with status {rc}" + (f": {said}" if said else "") + " (no summary.json)"
        elif rc not in (0, 1) or (said and "could not summarise" not in said and not summary.get("ok")):
            reason = said if said else f"fly exited with status {rc}"
    row = make_row(spec["run_id"], spec["factors"], summary, wall_s=round(wall, 3), reason=reason)
    write_atomic(run_dir / ROW_FILE, json.dumps(row, indent=1, default=str))
    return {"row": row, "summary": summary}
