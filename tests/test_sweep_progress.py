"""The sweep's progress display (tools/sweep_progress.py) and its wiring in `towerlink sweep`.

A fake clock and a StringIO stand for the wall clock and the terminal: plain lines when the stream
is not a terminal, a bar redrawn in place with each run's line above it when it is."""
from __future__ import annotations

import argparse
import io
import json
import re
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from tools.sweep_progress import Progress, fmt_s

ROOT = Path(__file__).resolve().parent.parent
PASS = {"pass": True, "reason": "", "wall_s": 9.94}
FAIL = {"pass": False, "reason": "goal 2 not reached in 120 s", "wall_s": 120.0}


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def screen(text: str) -> list[str]:
    """What a terminal shows: each line as left by its last carriage return."""
    return [ln.split("\r")[-1].rstrip() for ln in text.split("\n")]


def test_fmt_s():
    assert [fmt_s(s) for s in (0, 59.4, 59.6, 61, 3599, 3600, 3725, -3)] == \
        ["0:00", "0:59", "1:00", "1:01", "59:59", "1:00:00", "1:02:05", "0:00"]


def test_not_a_terminal_gives_one_plain_line_per_run_with_the_counts_and_no_carriage_returns():
    out, clock = io.StringIO(), Clock()
    with Progress(4, initial=1, initial_failed=1, stream=out, clock=clock) as p:
        p.running(2)
        clock.t += 10
        p.run_done("a1b2c3 seed=1", PASS)
        p.running(2)
        clock.t += 10
        p.run_done("d4e5f6 seed=2", FAIL)
        clock.t += 3700
        p.run_done("0789ab seed=3", {"pass": False, "reason": "Ray task failed: boom", "wall_s": None})
    assert "\r" not in out.getvalue()
    assert out.getvalue().splitlines() == [
        # resumed runs count as done (and the resumed failure as failed); ETA: 10 s a run, 2 left
        "[sweep] 2/4 done, 1 failed, elapsed 0:10, ETA 0:20 | a1b2c3 seed=1: pass, 9.9 s",
        "[sweep] 3/4 done, 2 failed, elapsed 0:20, ETA 0:10 | d4e5f6 seed=2: FAIL (goal 2 not reached in 120 s), "
        "120.0 s",
        "[sweep] 4/4 done, 3 failed, elapsed 1:02:00, ETA 0:00 | 0789ab seed=3: FAIL (Ray task failed: boom)",
    ]


def test_a_terminal_gets_a_bar_under_the_runs_lines_and_its_final_state_stays():
    out, clock = Tty(), Clock()
    with Progress(3, stream=out, clock=clock) as p:
        assert "\r" in out.getvalue() and screen(out.getvalue())[-1].startswith("[sweep] 0/3 |")
        assert screen(out.getvalue())[-1].endswith("0 failed, 0 in flight, elapsed 0:00, ETA ?")
        p.running(2)
        clock.t += 30
        p.running(2)            # the loop's wait: elapsed moves on
        assert screen(out.getvalue())[-1].endswith("| 0 failed, 2 in flight, elapsed 0:30, ETA ?")
        p.run_done("a1b2c3 seed=1", FAIL)
        bar = screen(out.getvalue())[-1]
        assert re.fullmatch(r"\[sweep\] 1/3 \|[^|]*\| 1 failed, 1 in flight, elapsed 0:30, ETA 1:00", bar), bar
        p.running(2)
        clock.t += 15
        p.run_done("d4e5f6 seed=2", PASS)
        p.run_done("0789ab seed=3", PASS)
    shown = screen(out.getvalue())
    assert out.getvalue().endswith("\n") and shown[-1] == ""        # the cursor is on a fresh line
    lines = [ln for ln in shown if ln]
    # every run's line in the scrollback, in order, above the bar; the bar's last state under them
    assert lines[:3] == ["[sweep] 1/3 a1b2c3 seed=1: FAIL (goal 2 not reached in 120 s), 120.0 s",
                         "[sweep] 2/3 d4e5f6 seed=2: pass, 9.9 s",
                         "[sweep] 3/3 0789ab seed=3: pass, 9.9 s"]
    assert re.fullmatch(r"\[sweep\] 3/3 \|#+\| 1 failed, 0 in flight, elapsed 0:45, ETA 0:00", lines[3]), lines[3]
    assert len(lines) == 4


def test_resumed_runs_start_the_bar_at_their_count():
    out = Tty()
    with Progress(10, initial=4, initial_failed=1, stream=out, clock=Clock()):
        assert re.fullmatch(r"\[sweep\] 4/10 \|#+ *\| 1 failed, 0 in flight, elapsed 0:00, ETA \?",
                            screen(out.getvalue())[-1])


def test_ctrl_c_closes_the_bar_and_leaves_a_clean_line():
    from tqdm import tqdm
    out = Tty()
    with pytest.raises(KeyboardInterrupt):
        with Progress(5, stream=out, clock=Clock()) as p:
            p.running(2)
            p.write("[sweep] interrupted: stopping 2 running flight(s)...")
            raise KeyboardInterrupt
    assert p._bar is None and not [b for b in tqdm._instances if b.fp is out]
    shown = [ln for ln in screen(out.getvalue()) if ln]
    assert out.getvalue().endswith("\n")
    assert shown[0] == "[sweep] interrupted: stopping 2 running flight(s)..."
    assert shown[1].startswith("[sweep] 0/5 |") and shown[1].endswith("2 in flight, elapsed 0:00, ETA ?")
    p.close()                   # twice is harmless
    assert out.getvalue().endswith("\n")


def test_tqdm_is_imported_only_for_a_bar_and_only_by_the_sweep():
    code = ("import io, sys; from tools.sweep_progress import Progress; "
            "p = Progress(2, stream=io.StringIO()); p.run_done('x', {'pass': True}); p.close(); "
            "import tools.sweep; print('tqdm' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert p.returncode == 0 and p.stdout.strip() == "False", p.stderr
    pattern = re.compile(r"^\s*(import tqdm\b|from tqdm\b)", re.M)
    users = sorted(str(f.relative_to(ROOT)) for d in ("gcs", "vehicle", "bridge", "tools", "examples")
                   for f in (ROOT / d).rglob("*.py") if pattern.search(f.read_text(errors="replace")))
    assert users == ["tools/sweep.py", "tools/sweep_progress.py"]     # the install check, the bar


# ----------------------------------------------------------------------------- wired into the sweep


class FakeRay:
    """Just what tools.sweep.execute uses: remote tasks, wait, get, cancel. The first wait returns
    the first run; the second wait is hit by Ctrl-C (the sweep's Interrupt raises there)."""
    __version__ = "0.fake"

    def __init__(self, summary: dict) -> None:
        self.summary, self.refs, self.cancelled, self.waits, self.shut = summary, [], [], 0, False

    def remote(self, **_opts):
        return lambda fn: SimpleNamespace(remote=self._submit)

    def _submit(self, spec):
        self.refs.append(spec)
        return len(self.refs) - 1

    def available_resources(self):
        return {"CPU": 2.0}

    def wait(self, refs, num_returns=1, timeout=None):
        self.waits += 1
        if self.waits == 1:
            return [refs[0]], refs[1:]
        if self.waits == 2:
            raise KeyboardInterrupt
        return list(refs), []       # the cancelled flights have stopped

    def get(self, ref):
        spec = self.refs[ref]
        return {"row": {"run_id": spec["run_id"], "pass": True, "reason": "", "wall_s": 5.0}, "summary": self.summary}

    def cancel(self, ref):
        self.cancelled.append(ref)

    def shutdown(self):
        self.shut = True


def test_the_sweep_shows_the_bar_writes_a_cluster_runs_summary_here_and_closes_the_bar_on_ctrl_c(
        tmp_path, monkeypatch):
    from tools import sweep
    fake = FakeRay({"follow_rms": 1.25})
    monkeypatch.setattr(sweep, "start_ray", lambda address, parallel: fake)
    term = Tty()
    monkeypatch.setattr(sys, "stdout", term)
    specs = [{"run_id": f"run{i}", "factors": {"seed": i}, "run_dir": str(tmp_path / "runs" / f"run{i}")}
             for i in range(3)]
    rows = {"old": {"run_id": "old", "pass": False, "reason": "x"}}     # resumed, failed
    args = SimpleNamespace(address="127.0.0.1:6379", parallel=2)
    ok = sweep._fly_all(args, specs, rows, 4, time.monotonic(), sweep.Interrupt())
    assert ok is False and fake.shut
    assert fake.cancelled == [1, 2] or fake.cancelled == [1]     # the flights still running were cancelled
    # the worker's summary and row were written on the driver (a cluster node's folder is its own)
    assert json.loads((tmp_path / "runs" / "run0" / "summary.json").read_text()) == {"follow_rms": 1.25}
    assert json.loads((tmp_path / "runs" / "run0" / "row.json").read_text())["run_id"] == "run0"
    assert set(rows) == {"old", "run0"}
    text = term.getvalue()
    assert text.endswith("\n")
    shown = [ln for ln in screen(text) if ln]
    assert shown[0] == "towerlink sweep: Ray 0.fake at 127.0.0.1:6379, 2 run(s) at once"
    assert shown[1] == "[sweep] 2/4 run0 seed=0: pass, 5.0 s"
    assert shown[2] == "[sweep] interrupted: stopping 2 running flight(s)..."
    # the bar's last state: the cancelled flights have stopped
    assert re.fullmatch(r"\[sweep\] 2/4 \|#+ *\| 1 failed, 0 in flight, elapsed 0:0\d, ETA 0:\d\d", shown[3]), \
        shown[3]
    assert len(shown) == 4


def test_a_cluster_that_cannot_be_reached_is_exit_2_with_why_not_a_traceback(tmp_path, monkeypatch, capsys):
    import types

    from tools import sweep

    class AuthenticationError(Exception):
        pass

    def init(address=None, **_kw):
        try:
            raise AuthenticationError("RPC error: InvalidAuthToken: Authentication token is missing or incorrect")
        except AuthenticationError as exc:
            raise ConnectionError(f"Failed to connect to Ray cluster at {address}") from exc

    fake = types.ModuleType("ray")
    fake.init, fake.__version__ = init, "0.fake"
    monkeypatch.setitem(sys.modules, "ray", fake)
    parser = argparse.ArgumentParser()
    sweep.add_arguments(parser)
    args = parser.parse_args(["--seeds", "1", "--out", str(tmp_path / "s"), "--address", "127.0.0.1:6379"])
    assert sweep.run(args) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == (
        "towerlink sweep: cannot connect to the Ray cluster at 127.0.0.1:6379: ConnectionError: Failed to connect to "
        "Ray cluster at 127.0.0.1:6379; the cluster wants its token: set RAY_AUTH_MODE=token and give the token "
        "(RAY_AUTH_TOKEN, or the file ~/.ray/auth_token)")
    assert "Traceback" not in err
