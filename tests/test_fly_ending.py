"""How `towerlink fly` ends a run: the tower's last line wakes the launcher (tools.fly_progress), which
sees the tower's exit as it happens and signals every other process once (tools.fly_processes)."""
from __future__ import annotations

import signal
import subprocess
import sys
import time

from support import wait_until
from tools.fly_processes import ProcessGroup
from tools.fly_progress import TowerOutput


def _sleeper(group: ProcessGroup, name: str, code: str = "") -> subprocess.Popen:
    """A child that logs each SIGTERM it gets and ends 0.3 s after the first (or runs `code` once
    its handler is in)."""
    prog = ("import signal, sys, time\n"
            "n = 0\n"
            "def on(*_):\n"
            "    global n\n"
            "    n += 1\n"
            "    print('term', n, flush=True)\n"
            "signal.signal(signal.SIGTERM, on)\n"
            "print('ready', flush=True)\n"
            + (code or "while n < 1:\n    signal.pause()\ntime.sleep(0.3)\nprint('bye', n, flush=True)\n"))
    return group.start(name, [sys.executable, "-c", prog])


def _ready(group: ProcessGroup, name: str) -> None:
    # a line of its own: the command line in the log has the word too
    wait_until(lambda: "ready" in (group.dir / f"{name}.log").read_text().splitlines(), 20, f"{name} ready")


def test_a_process_told_to_stop_is_signalled_once_and_stop_then_waits(tmp_path):
    group = ProcessGroup(tmp_path)
    p = _sleeper(group, "w")
    _ready(group, "w")
    group.tell_to_stop("w", signal.SIGTERM)
    group.tell_to_stop("w", signal.SIGTERM)       # once only
    group.stop("w", signal.SIGTERM)               # waits; no second signal in its last steps
    group.close_logs()
    assert p.returncode == 0
    log = (tmp_path / "w.log").read_text()
    assert "term 1" in log and "term 2" not in log and "bye 1" in log


def test_wait_gives_the_exit_status_when_it_ends_and_none_while_it_runs(tmp_path):
    group = ProcessGroup(tmp_path)
    _sleeper(group, "w", "signal.pause()\nsys.exit(3)\n")
    _ready(group, "w")
    assert group.wait("w", 0.05) is None
    group.tell_to_stop("w", signal.SIGTERM)
    t = time.monotonic()
    assert group.wait("w", 20) == 3
    assert time.monotonic() - t < 10
    group.close_logs()


def test_the_towers_last_line_says_the_mission_is_over():
    out = TowerOutput()
    out.feed("tower: goal 1/1 reached at t=12.3 s")
    assert not out.over.is_set()
    out.feed("tower: MISSION FAILED: 0/1 goals reached (interrupted)")
    assert out.over.is_set()
