"""A real sweep on a local Ray: two runs through `towerlink sweep` as a user types it (slow).

The two runs differ only in the scenario's name, so with the same seed in lockstep they must give
the same figures; a second invocation finds both finished and flies nothing."""
from __future__ import annotations

import csv
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow
pytest.importorskip("ray", reason="towerlink sweep needs Ray: pip install -e '.[sweep]'")
pq = pytest.importorskip("pyarrow.parquet", reason="towerlink sweep needs pyarrow: pip install -e '.[sweep]'")

ROOT = Path(__file__).resolve().parent.parent
# figures of the mission itself (sim time, truth); bridge packet counts and the like are not compared
MISSION = ("follow_rms", "wobble_rms", "ratio_mean", "ratio_max", "mission_s", "goals.", "follow_error.",
           "wobble.", "flight.", "mission_window_sim.", "limits.")


def sweep(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
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


def _listening(port: int) -> bool:
    import socket
    try:
        socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
        return True
    except OSError:
        return False


def _ray_procs(marker: str) -> list[str]:
    out = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if marker in cmd:
            out.append(f"{pid} {cmd[:120]}")
    return out


def test_a_sweep_on_a_running_ray_cluster_by_its_address(tmp_path):
    """`ray start --head` (token authentication, as Ray sets it up), then `towerlink sweep
    --address HOST:PORT` as its --help says: the run flies on the cluster's workers, its row
    comes back, a rerun against the cluster flies nothing; the cluster is stopped after."""
    import secrets
    import tempfile

    from support import free_port, wait_until
    port = free_port()
    temp = tempfile.mkdtemp(prefix="rc", dir="/tmp")        # short: Ray's unix socket paths
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RAY_USAGE_STATS_ENABLED": "0",
           "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(32)}
    ray_cli = Path(sys.executable).with_name("ray")
    head = subprocess.Popen([str(ray_cli), "start", "--head", "--block", "--port", str(port), "--num-cpus", "2",
                             "--include-dashboard=false", "--disable-usage-stats", "--temp-dir", temp,
                             "--object-store-memory", str(128 * 1024 * 1024)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, env=env, cwd=ROOT,
                            start_new_session=True)
    try:
        wait_until(lambda: _listening(port), 60, "the Ray head's GCS port")
        out = tmp_path / "sweep"
        args = [sys.executable, "-m", "tools.cli", "sweep", "--set", "mission.goals=[[-131.039, 73.524]]",
                "--set", "finish=none", "--seeds", "7", "--timeout", "120", "--out", str(out),
                "--address", f"127.0.0.1:{port}"]
        p = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, env=env, timeout=240)
        assert p.returncode == 0, p.stdout + p.stderr
        assert f"at 127.0.0.1:{port}, 1 run(s) at once" in p.stdout
        assert "towerlink sweep: 1 runs, 0 failed" in p.stdout
        with open(out / "results.csv") as f:
            (row,) = list(csv.DictReader(f))
        assert row["pass"] == "True" and row["seed"] == "7" and float(row["follow_rms"]) > 0
        assert (out / "runs" / row["run_id"] / "summary.json").exists()
        again = subprocess.run(args, capture_output=True, text=True, cwd=ROOT, env=env, timeout=120)
        assert again.returncode == 0 and "(0 to fly, 1 already finished)" in again.stdout, again.stdout
    finally:
        # the whole session: `ray start --block` stops its processes gracefully in about 30 s;
        # they are this test's alone (their own session, their own --temp-dir), so no grace
        os.killpg(head.pid, signal.SIGKILL)
        head.wait(30)
        wait_until(lambda: not _ray_procs(temp), 30, f"the cluster's processes ({temp}) to end")
        shutil.rmtree(temp, ignore_errors=True)


def test_an_address_where_no_cluster_listens_is_refused_at_once(tmp_path):
    from support import free_port
    p = sweep("--seeds", "1", "--out", str(tmp_path / "s"), "--address", f"127.0.0.1:{free_port()}")
    assert p.returncode == 2
    assert "cannot join the Ray cluster at 127.0.0.1:" in p.stderr and "nothing accepts a connection" in p.stderr
    assert "Traceback" not in p.stderr
