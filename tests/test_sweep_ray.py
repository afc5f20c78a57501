"""A real sweep on a local Ray: two runs through `towerlink sweep` as a user types it (slow).

The two runs differ only in the scenario's name, so with the same seed in lockstep they must give
the same figures; a second invocation finds both finished and flies nothing."""
from __future__ import annotations

import csv
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

import pytest

from support import free_port, wait_until

pytestmark = pytest.mark.slow
ray = pytest.importorskip("ray", reason="towerlink sweep needs Ray: pip install -e '.[sweep]'")
pq = pytest.importorskip("pyarrow.parquet", reason="towerlink sweep needs pyarrow: pip install -e '.[sweep]'")

ROOT = Path(__file__).resolve().parent.parent
# figures of the mission itself (sim time, truth); bridge packet counts and the like are not compared
MISSION = ("follow_rms", "wobble_rms", "ratio_mean", "ratio_max", "mission_s", "goals.", "follow_error.",
           "wobble.", "flight.", "mission_window_sim.", "limits.")


def sweep(*args: str, env_extra: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(env_extra or {})}
    return subprocess.run([sys.executable, "-m", "tools.cli", "sweep", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=240)


def test_two_runs_on_local_ray_same_seed_same_figures_and_a_rerun_resumes(tmp_path):
    out = tmp_path / "sweep"
    args = ("--set", "mission.goals=[[-131.039, 73.524]]", "--set", "finish=none", "--set", "name=twin-a,twin-b",
            "--seeds", "7", "--parallel", "2", "--timeout", "120", "--out", str(out))
    p = sweep(*args)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "2 runs of default.toml (2 to fly, 0 already finished) varying name" in p.stdout
    assert "towerlink sweep: 2 runs, 0 failed" in p.stdout

    with open(out / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["name"] for r in rows] == ["twin-a", "twin-b"]
    assert all(r["pass"] == "True" and r["seed"] == "7" and r["finish"] == "none" for r in rows)
    table = pq.read_table(out / "results.parquet").to_pylist()
    assert [r["run_id"] for r in table] == [r["run_id"] for r in rows]
    assert table[0]["seed"] == 7 and table[0]["pass"] is True and table[0]["goals.0.reached"] == 1.0

    figures = [k for k in table[0] if k.startswith(MISSION)]
    assert {"follow_rms", "wobble_rms", "goals.0.time_to_reach", "follow_error.rms"} <= set(figures)
    a, b = table
    assert a["follow_rms"] is not None and a["goals.0.time_to_reach"] > 0
    assert {k: a[k] for k in figures} == {k: b[k] for k in figures}

    stamps = {r["run_id"]: (out / "runs" / r["run_id"] / "row.json").stat().st_mtime_ns for r in rows}
    assert (out / "sweep.png").stat().st_size > 10_000 and "follow_rms" in (out / "effects.txt").read_text()

    again = sweep(*args)
    assert again.returncode == 0, again.stdout + again.stderr
    assert "(0 to fly, 2 already finished)" in again.stdout and "Ray" not in again.stdout
    assert "2 runs (2 resumed), 0 failed" in again.stdout
    assert {rid: (out / "runs" / rid / "row.json").stat().st_mtime_ns for rid in stamps} == stamps
    with open(out / "results.csv") as f:
        assert [r["run_id"] for r in csv.DictReader(f)] == [r["run_id"] for r in rows]


# ----------------------------------------------------------------------------- a real Ray cluster


def _pids_of(marker: str) -> list[int]:
    """Processes whose command line holds `marker` (this test's own Ray temp dir)."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and int(entry) != os.getpid():
            try:
                cmd = Path("/proc", entry, "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                state = Path("/proc", entry, "stat").read_text().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            if marker in cmd and state != "Z":
                pids.append(int(entry))
    return pids


@contextmanager
def ray_head(env: dict[str, str], leftovers: list[int]):
    """A Ray head node of 2 CPUs started with the ray CLI (`ray start --head --block`), yielding its
    address HOST:PORT. Stopped by SIGTERM to that command, which stops its processes; `ray stop`
    is not used: it stops every Ray on the machine (a parallel test's, a developer's). Any process
    of this cluster still there afterwards is put in `leftovers` and killed."""
    temp = Path(tempfile.mkdtemp(prefix="rt", dir="/tmp"))     # short: Ray's unix sockets live under it
    port = free_port(socket.SOCK_STREAM)
    log = open(temp / "head.log", "w+")
    head = subprocess.Popen(
        [str(Path(sys.executable).with_name("ray")), "start", "--head", "--block", "--port", str(port),
         "--node-ip-address", "127.0.0.1", "--num-cpus", "2", "--include-dashboard=false",
         "--disable-usage-stats", "--temp-dir", str(temp)],
        env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        wait_until(lambda: (temp / "ray_current_cluster").exists() or head.poll() is not None, 90, "ray start --head",
                   interval=0.1)
        assert head.poll() is None, (temp / "head.log").read_text()
        yield f"127.0.0.1:{port}"
    finally:
        head.terminate()
        try:
            head.wait(timeout=30)
        except subprocess.TimeoutExpired:
            head.kill()
            head.wait()
        log.close()
        try:
            wait_until(lambda: not _pids_of(str(temp)), 20, "the cluster's processes to end", interval=0.2)
        except Exception:  # noqa: BLE001 - recorded and killed below
            pass
        leftovers.extend(_pids_of(str(temp)))
        for pid in leftovers:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        shutil.rmtree(temp, ignore_errors=True)


def test_two_runs_on_a_ray_cluster_started_with_ray_start_then_a_rerun_resumes(tmp_path):
    # the cluster wants a token (as `ray start` does once ~/.ray/auth_token exists); the driver gives it
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32),
           "RAY_USAGE_STATS_ENABLED": "0"}
    out = tmp_path / "sweep"
    leftovers: list[int] = []
    with ray_head(env, leftovers) as address:
        args = ("--set", "mission.goals=[[-131.039, 73.524]]", "--set", "finish=none", "--seeds", "3,4",
                "--timeout", "120", "--out", str(out), "--address", address)
        p = sweep(*args, env_extra=env)
        assert p.returncode == 0, p.stdout + p.stderr
        assert f"towerlink sweep: Ray {ray.__version__} at {address}, 2 run(s) at once" in p.stdout
        assert "towerlink sweep: 2 runs, 0 failed" in p.stdout
        done = [ln for ln in p.stdout.splitlines() if ln.startswith("[sweep] ")]
        assert len(done) == 2 and all(": pass, " in ln and "\r" not in ln for ln in done), p.stdout
        with open(out / "results.csv") as f:
            rows = list(csv.DictReader(f))
        assert sorted(r["seed"] for r in rows) == ["3", "4"] and all(r["pass"] == "True" for r in rows)
        for r in rows:      # each run's summary and row are on the driver's side
            summary = json.loads((out / "runs" / r["run_id"] / "summary.json").read_text())
            assert summary["ok"] is True and summary["goals"][0]["reached"]
            assert json.loads((out / "runs" / r["run_id"] / "row.json").read_text())["pass"] is True
        stamps = {r["run_id"]: (out / "runs" / r["run_id"] / "row.json").stat().st_mtime_ns for r in rows}

        again = sweep(*args, env_extra=env)
        assert again.returncode == 0, again.stdout + again.stderr
        assert "(0 to fly, 2 already finished)" in again.stdout and "Ray" not in again.stdout
        assert {rid: (out / "runs" / rid / "row.json").stat().st_mtime_ns for rid in stamps} == stamps
    assert leftovers == [], "Ray processes of the cluster were still running after it was stopped"
