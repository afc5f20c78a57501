"""The sweep's table (flatten, rows, columns, effects), one run's runner without Ray, and the CLI's
refusals (a bad plan, no Ray) — all fast."""
from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tools import sweep_run
from tools import sweep_table as t

ROOT = Path(__file__).resolve().parent.parent

SUMMARY = {
    "ok": True, "scenario": "lab", "goals_reached": 2, "goals_total": 2,
    "goals": [{"index": 1, "tower": [1.0, 2.0], "ratio": 0.95, "reached": True, "error": None},
              {"index": 2, "tower": [3.0, 4.0], "ratio": 1.25, "reached": True, "error": None}],
    "follow_error": {"rms": 0.5, "max": 0.9, "n": 300, "by": "bridge tf follow (sysid 2)"},
    "wobble": {"drone": {"rms": 1.4, "max": 3.0, "n": 100}, "drone_yaw": {"rms": 0.0, "max": 0.0, "n": 100},
               "follow_frame": "drone", "ratio_rms": math.inf},
    "mission_window_sim": [10.0, 40.5], "speedup": "max", "achieved_speedup": 4.2, "seed": 3,
    "ports": {"drone": 20001}, "tower_error": None,
}


def test_flatten_keeps_every_finite_number_with_dotted_names():
    f = t.flatten(SUMMARY)
    assert f["follow_error.rms"] == 0.5 and f["goals.1.ratio"] == 1.25 and f["goals.0.tower.1"] == 2.0
    assert f["ok"] == 1.0 and f["goals.0.reached"] == 1.0 and f["mission_window_sim.1"] == 40.5
    assert "wobble.ratio_rms" not in f            # inf is not a figure
    assert "achieved_speedup" not in f            # the wall clock, not the mission
    assert not any(k.startswith("ports") for k in f) and "speedup" not in f and "scenario" not in f


@given(st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=4)),
                    lambda c: st.one_of(st.lists(c, max_size=3), st.dictionaries(st.text(min_size=1, max_size=3), c,
                                                                                  max_size=3)), max_leaves=15))
def test_flatten_gives_only_finite_floats(d):
    f = t.flatten({"x": d})
    assert all(isinstance(v, float) and math.isfinite(v) for v in f.values())
    assert all(k == "x" or k.startswith("x.") for k in f)


def test_key_figures_use_the_frame_the_rover_followed():
    k = t.key_figures(SUMMARY)
    assert k == {"follow_rms": 0.5, "wobble_rms": 1.4, "ratio_mean": pytest.approx(1.1), "ratio_max": 1.25,
                 "mission_s": 30.5, "failsafe_s": None}
    yaw = dict(SUMMARY, wobble=dict(SUMMARY["wobble"], follow_frame="drone_yaw"))
    assert t.key_figures(yaw)["wobble_rms"] == 0.0
    assert t.key_figures({}) == dict.fromkeys(t.KEY_FIGURES)
    # the fault section: the earliest fault -> failsafe delay of the run
    faults = {"faults": [{"failsafes": [{"after": 4.5}, {"after": 6.0}]}, {"failsafes": [{"after": 2.25}]}]}
    assert t.key_figures(dict(SUMMARY, faults=faults))["failsafe_s"] == 2.25
    rows = [t.make_row("a", {}, dict(SUMMARY, faults=faults), wall_s=1.0), t.make_row("b", {}, SUMMARY, wall_s=1.0)]
    assert t.effect_figures(rows) == ("follow_rms", "wobble_rms", "ratio_mean", "failsafe_s")
    assert t.effect_figures(rows[1:]) == ("follow_rms", "wobble_rms", "ratio_mean")


def test_rows_pass_and_fail_with_their_reason():
    ok = t.make_row("r1", {"seed": 3, "wind": [8.0, 270.0, 1.0]}, SUMMARY, wall_s=9.5)
    assert (ok["pass"], ok["reason"], ok["seed"], ok["wind"], ok["follow_rms"]) == (True, "", 3, "[8.0,270.0,1.0]", 0.5)
    missed = dict(SUMMARY, ok=False, goals_reached=1)
    assert t.make_row("r2", {}, missed, wall_s=1.0)["reason"] == "1/2 goals reached"
    failsafes = [{"vehicle": "rover", "text": "GCS Failsafe On: Hold", "t": 24.5},
                 {"vehicle": "drone", "text": "GCS Failsafe On: RTL", "t": 24.26}]
    lost = dict(missed, faults={"faults": [], "failsafes": failsafes})
    assert t.make_row("r2", {}, lost, wall_s=1.0)["reason"] == \
        "1/2 goals reached; after drone: 'GCS Failsafe On: RTL' at 24.26 s"
    tower = dict(SUMMARY, ok=False, tower_error="goal 2 not reached in 120 s")
    assert t.make_row("r3", {}, tower, wall_s=1.0)["reason"] == "goal 2 not reached in 120 s"
    timed = t.make_row("r4", {"seed": 1}, SUMMARY, wall_s=700.0, reason="timed out after 600 s wall")
    assert (timed["pass"], timed["reason"]) == (False, "timed out after 600 s wall")
    none = t.make_row("r5", {"seed": 1}, None, wall_s=None, reason="fly exited with status 2")
    assert none["pass"] is False and none["follow_rms"] is None


def test_columns_and_normalise_give_one_type_per_column():
    rows = [t.make_row("a", {"seed": 1, "x": 0.1}, SUMMARY, wall_s=1.0),
            t.make_row("b", {"seed": 2, "x": "big"}, None, wall_s=None, reason="crashed"),
            t.make_row("c", {"seed": 3, "x": 2}, dict(SUMMARY, extra={"n": 4}), wall_s=2)]
    cols = t.columns(rows, ["seed", "x"])
    assert cols[:7] == ["run_id", "seed", "x", "pass", "reason", "wall_s", "follow_rms"]
    assert "extra.n" in cols and len(cols) == len(set(cols))
    norm = t.normalise(rows, cols)
    assert [r["seed"] for r in norm] == [1, 2, 3]                    # all ints stay ints
    assert [r["x"] for r in norm] == ["0.1", "big", "2"]             # mixed: text
    assert [r["wall_s"] for r in norm] == [1.0, None, 2.0]           # numbers: floats
    assert norm[1]["extra.n"] is None and norm[2]["extra.n"] == 4.0
    import pyarrow as pa
    pytest.importorskip("pyarrow")
    table = pa.Table.from_pylist(norm)
    assert table.schema.field("seed").type == pa.int64() and table.schema.field("x").type == pa.string()


def test_effects_per_level_mean_std_and_pass_rate():
    def row(level, fe, ok):
        return {"f": level, "pass": ok, "follow_rms": fe, "wobble_rms": None, "ratio_mean": 1.0}
    rows = [row(0.2, 1.0, True), row(0.0, 0.5, True), row(0.2, 3.0, False), row(0.0, 0.7, True)]
    eff = t.effects(rows, ["f"])
    assert [e["level"] for e in eff] == [0.0, 0.2]                   # numeric levels sorted
    lo, hi = eff
    assert (lo["runs"], lo["pass_rate"], hi["pass_rate"]) == (2, 1.0, 0.5)
    assert lo["follow_rms_mean"] == pytest.approx(0.6) and lo["follow_rms_std"] == pytest.approx(math.sqrt(0.02))
    assert hi["follow_rms_mean"] == 2.0 and lo["wobble_rms_mean"] is None
    text = t.format_effects(eff)
    assert "0.600 ± 0.141" in text and "50%" in text and text.splitlines()[0].startswith("factor")


def test_summary_line():
    rows = [{"pass": True}, {"pass": False}, {"pass": True}]
    assert t.summary_line(rows, 60.0, skipped=1) == "3 runs (1 resumed), 1 failed, 60 s wall, 2.0 runs/min"


# ----------------------------------------------------------------------------- one run, no Ray


def spec(tmp_path, argv, timeout=30.0):
    return {"run_id": "rtest", "factors": {"seed": 1}, "run_dir": str(tmp_path / "runs" / "rtest"),
            "argv": argv, "timeout": timeout, "scenario_toml": None, "root": str(ROOT)}


def test_a_fly_that_refuses_is_a_failed_row_with_flys_reason(tmp_path):
    res = sweep_run.run_one(spec(tmp_path, ["fly", str(tmp_path / "missing.toml"), "--lockstep", "-q",
                                            "--out", str(tmp_path / "runs" / "rtest")]))
    row = res["row"]
    assert row["pass"] is False and "no such scenario file" in row["reason"] and "status 2" in row["reason"]
    saved = json.loads((tmp_path / "runs" / "rtest" / "row.json").read_text())
    assert saved["reason"] == row["reason"]
    assert sweep_run.finished(tmp_path / "runs" / "rtest")["reason"] == row["reason"]


def test_a_run_that_hangs_is_stopped_and_is_a_timed_out_row(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_run, "GRACE_S", 0.5)
    # a world with no ports runs until it is told to stop
    res = sweep_run.run_one(spec(tmp_path, ["sitl", "--no-save", "--tcp-base", "0", "--udp-base", "0",
                                            "--drones", "1", "--rovers", "0"], timeout=0.5))
    assert res["row"]["pass"] is False and res["row"]["reason"].startswith("timed out")
    log = (tmp_path / "runs" / "rtest" / "fly.log").read_text()
    assert "sitl" in log


def test_stopping_a_run_also_stops_what_it_started_in_sessions_of_its_own(tmp_path):
    # as fly starts the world, bridge and tower: a child in its own session, which a signal to
    # the parent's group does not reach; the parent exits on SIGINT and leaves it behind
    script = tmp_path / "parent.py"
    script.write_text(
        "import signal, subprocess, sys\n"
        "c = subprocess.Popen([sys.executable, '-c', 'import signal; signal.pause()'], start_new_session=True)\n"
        "print(c.pid, flush=True)\n"
        "signal.pause()\n")
    p = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True, start_new_session=True)
    child = int(p.stdout.readline())
    try:
        assert sweep_run._alive(child)
        sweep_run._stop(p, grace=5.0)
        assert p.poll() is not None and not sweep_run._alive(child)
    finally:
        for pid in (p.pid, child):
            try:
                os.kill(pid, 9)
            except ProcessLookupError:
                pass
        p.wait(5)


def test_a_failed_missions_reason_is_flys_last_word_not_its_list_of_files(tmp_path):
    # the tail of a real fly.log (make sweep, tower_loss=0.05 seed=2): the reason was the file list
    log = tmp_path / "fly.log"
    log.write_text("   4/4   [ -146.04,   99.50]  [ -4.00,  28.00]    30.0   MISSED    8.50      -        -\n\n"
                   "hover (no wind): the drone did not hover\n"
                   "tower: TakeoffError: command MAV_CMD_NAV_TAKEOFF rejected: FAILED\n"
                   f"run folder {tmp_path}: bridge.log bridge.tlog fly.log summary.json tower.log\n")
    assert sweep_run._fly_reason(log) == "tower: TakeoffError: command MAV_CMD_NAV_TAKEOFF rejected: FAILED"
    # with a summary, only fly's own word: the row says the rest (the goals, the first failsafe)
    assert sweep_run._fly_reason(log, own_only=True) is None
    log.write_text("towerlink fly: timed out after 300 s wall; all processes stopped\nrun folder x: a b\n")
    assert sweep_run._fly_reason(log) == "timed out after 300 s wall"
    assert sweep_run._fly_reason(log, own_only=True) == "timed out after 300 s wall"


def test_finished_needs_a_complete_row_and_summary(tmp_path):
    d = tmp_path / "r"
    d.mkdir()
    assert sweep_run.finished(d) is None
    (d / "summary.json").write_text(json.dumps(SUMMARY))
    assert sweep_run.finished(d) is None                         # no row: the run was cut short
    (d / "row.json").write_text('{"pass": tr')                    # damaged
    assert sweep_run.finished(d) is None
    sweep_run.write_atomic(d / "row.json", json.dumps({"pass": True, "reason": ""}))
    assert sweep_run.finished(d) == {"pass": True, "reason": ""}
    (d / "summary.json").write_text("{")                          # summary damaged, row says pass
    assert sweep_run.finished(d) is None
    assert not [p for p in d.iterdir() if p.name.endswith(".tmp")]


# ----------------------------------------------------------------------------- the CLI's refusals


def towerlink(*args, env_extra=None):
    env = {**os.environ, "PYTHONPATH": str(ROOT), **(env_extra or {})}
    return subprocess.run([sys.executable, "-m", "tools.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=60)


@pytest.mark.parametrize("missing, said", [("ray", "pip install 'towerlink[sweep]'"),
                                            # an install of the sweep extra from before tqdm was in it
                                            ("tqdm", "needs Ray, pyarrow and tqdm")])
def test_sweep_without_its_extra_says_how_to_install_it(tmp_path, missing, said):
    """Said before Ray starts, without a traceback, and nothing written."""
    fake = tmp_path / f"no_{missing}" / missing
    fake.mkdir(parents=True)
    (fake / "__init__.py").write_text(f"raise ImportError('No module named {missing}')\n")
    env = {"PYTHONPATH": f"{fake.parent}{os.pathsep}{ROOT}"}
    p = towerlink("sweep", "--seeds", "1", "--out", str(tmp_path / "s"), env_extra=env)
    assert p.returncode == 2, p.stdout + p.stderr
    assert said in p.stderr and "pip install 'towerlink[sweep]'" in p.stderr
    assert "Traceback" not in p.stderr and not (tmp_path / "s").exists()


def test_a_cluster_that_refuses_the_token_is_exit_2_saying_what_to_set(tmp_path, monkeypatch, capsys):
    import argparse
    import socket
    import types

    from tools import sweep

    class RayError(Exception):
        pass

    def init(address=None, **_kw):      # what Ray 2.60 raises when the GCS refuses the token
        try:
            raise RayError("RPC error: InvalidAuthToken: Authentication token is missing or incorrect")
        except RayError as exc:
            raise ConnectionError("Failed to connect to Ray cluster at 192.0.2.2:6379") from exc

    fake = types.ModuleType("ray")
    fake.init, fake.__version__, fake.exceptions = init, "0.fake", types.SimpleNamespace(RayError=RayError)
    monkeypatch.setitem(sys.modules, "ray", fake)
    monkeypatch.setattr(os, "environ", dict(os.environ))        # start_ray sets PYTHONPATH, RAY_*
    with socket.socket() as head:       # something listens at the address (the GCS port)
        head.bind(("127.0.0.1", 0))
        head.listen()
        address = f"127.0.0.1:{head.getsockname()[1]}"
        parser = argparse.ArgumentParser()
        sweep.add_arguments(parser)
        assert sweep.run(parser.parse_args(["--seeds", "1", "--out", str(tmp_path / "s"),
                                            "--address", address])) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == (
        f"towerlink sweep: cannot join the Ray cluster at {address}: ConnectionError: Failed to connect to Ray "
        "cluster at 192.0.2.2:6379; it wants its token: set RAY_AUTH_MODE=token and give the token "
        "(RAY_AUTH_TOKEN, or the file ~/.ray/auth_token)")
    assert "Traceback" not in err


def test_sweep_refuses_a_bad_plan_before_anything_starts(tmp_path):
    p = towerlink("sweep", "--set", "tower_loss=0,2", "--out", str(tmp_path / "s"))
    assert p.returncode == 2 and "tower_loss: 2 is outside 0 <= loss < 1" in p.stderr
    assert "Traceback" not in p.stderr and not (tmp_path / "s").exists()
    p = towerlink("sweep", "--resume", "--out", str(tmp_path / "nothing"))
    assert p.returncode == 2 and "sweep.json is missing" in p.stderr


def test_sweep_dry_run_lists_the_runs():
    p = towerlink("sweep", "--dry-run", "--grid", "examples/sweep/frames_loss.toml")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[-1] == "12 runs of default.toml; varying: follow_frame, tower_loss, seed"
    assert len({ln.split()[0] for ln in lines[:-1]}) == 12
    # the faults example: its scenario file lies beside it (a sweep file's relative scenario)
    p = towerlink("sweep", "--dry-run", "--grid", "examples/sweep/faults.toml")
    assert p.returncode == 0, p.stderr
    assert p.stdout.splitlines()[-1] == \
        "8 runs of faults_lab.toml; varying: FS_GCS_ENABLE, faults.0.duration, tower_link.latency"


@pytest.mark.parametrize("lib, only", [("ray", ["tools/sweep.py"]), ("tqdm", ["tools/sweep_progress.py"])])
def test_only_the_sweep_imports_its_extra(lib, only):
    import re
    pattern = re.compile(rf"^\s*(import {lib}\b|from {lib}\b)", re.M)
    users = sorted(str(p.relative_to(ROOT)) for d in ("gcs", "vehicle", "bridge", "tools", "examples")
                   for p in (ROOT / d).rglob("*.py") if pattern.search(p.read_text(errors="replace")))
    assert users == only


class _Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_progress_without_a_terminal_is_one_plain_line_per_run_with_counts_and_eta():
    import io

    from tools.sweep_progress import Progress
    out, clock = io.StringIO(), _Clock()
    p = Progress(5, done=1, stream=out, clock=clock)         # one finished before: resumed
    assert p.bar is None and p.eta() is None
    p.started(2)
    clock.t += 30
    p.finished("ab12 seed=1", True, wall_s=29.96)
    clock.t += 30
    p.finished("cd34 seed=2", False, reason="timed out: fly did not end within 330 s wall")
    p.close()
    lines = out.getvalue().splitlines()
    assert lines == ["[sweep] 2/5 done, 0 failed, elapsed 0:30, ETA 1:30 | ab12 seed=1: pass, 30.0 s",
                     "[sweep] 3/5 done, 1 failed, elapsed 1:00, ETA 1:00 | cd34 seed=2: "
                     "FAIL (timed out: fly did not end within 330 s wall)"]
    assert "\r" not in out.getvalue()


def test_progress_on_a_terminal_is_a_bar_with_each_run_written_above_it():
    import io

    from tools.sweep_progress import Progress
    out = io.StringIO()
    p = Progress(4, done=1, failed=1, stream=out, tty=True)
    p.started(2)
    p.finished("ab12 seed=1", True, wall_s=12.0)
    p.finished("cd34 seed=2", False, reason="mission failed")
    p.close()
    text = out.getvalue()
    frames = [f for f in text.split("\r") if "flying" in f]          # the bar as redrawn
    assert "[sweep] ab12 seed=1: pass, 12.0 s\n" in text and "[sweep] cd34 seed=2: FAIL (mission failed)\n" in text
    assert any("1/4, 1 failed, 2 flying" in f for f in frames)       # resumed: starts at 1 done
    assert "3/4, 2 failed, 0 flying" in frames[-1]                     # as it ended, left drawn
    assert text.endswith("\n")


class _FakeRay:
    """What tools.sweep.execute uses of Ray: remote tasks, wait, get, cancel. The first wait gives
    the first run; Ctrl-C comes during the second; then the cancelled flights have stopped."""
    __version__ = "0.fake"

    def __init__(self, summary: dict) -> None:
        self.summary, self.specs, self.cancelled, self.waits, self.shut = summary, [], [], 0, False

    def remote(self, **_opts):
        return lambda fn: types.SimpleNamespace(remote=self._submit)

    def _submit(self, spec):
        self.specs.append(spec)
        return len(self.specs) - 1

    def available_resources(self):
        return {"CPU": 2.0}

    def wait(self, refs, num_returns=1, timeout=None):
        self.waits += 1
        if self.waits == 1:
            return [refs[0]], refs[1:]
        if self.waits == 2:
            raise KeyboardInterrupt
        return list(refs), []

    def get(self, ref):
        return {"row": {"run_id": self.specs[ref]["run_id"], "pass": True, "reason": "", "wall_s": 5.0},
                "summary": self.summary}

    def cancel(self, ref):
        self.cancelled.append(ref)

    def shutdown(self):
        self.shut = True


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_sweep_on_a_terminal_a_cluster_runs_summary_comes_back_and_ctrl_c_leaves_one_bar(tmp_path, monkeypatch):
    from tools import sweep
    fake = _FakeRay({"ok": True, "follow_rms": 1.25})
    monkeypatch.setattr(sweep, "start_ray", lambda address, parallel: fake)
    term = _Tty()
    monkeypatch.setattr(sys, "stdout", term)
    specs = [{"run_id": f"run{i}", "factors": {"seed": i}, "run_dir": str(tmp_path / "runs" / f"run{i}")}
             for i in range(3)]
    rows = {"old": {"run_id": "old", "pass": False, "reason": "x"}}     # resumed, failed
    ok = sweep._fly_all(types.SimpleNamespace(address="10.0.0.9:6379", parallel=2), specs, rows, 4,
                        sweep.Interrupt())
    assert ok is False and fake.shut and fake.cancelled == [1, 2]
    # a cluster worker's folder is on its node: the summary and row it returned are written here
    assert json.loads((tmp_path / "runs" / "run0" / "summary.json").read_text())["follow_rms"] == 1.25
    assert json.loads((tmp_path / "runs" / "run0" / "row.json").read_text())["run_id"] == "run0"
    assert set(rows) == {"old", "run0"}
    text = term.getvalue()
    shown = [ln.split("\r")[-1].rstrip() for ln in text.split("\n")]   # what the terminal keeps
    shown = [ln for ln in shown if ln]
    assert text.endswith("\n")
    assert shown[:3] == ["towerlink sweep: Ray 0.fake at 10.0.0.9:6379, 2 run(s) at once",
                         "[sweep] run0 seed=0: pass, 5.0 s",
                         "[sweep] interrupted: stopping 2 running flight(s)..."]
    # one bar, under the lines, as it ended: 2 of 4 done (1 resumed), the cancelled flights stopped
    assert len(shown) == 4 and "2/4, 1 failed, 0 flying" in shown[3], shown
