"""Helpers for the tests of towerlink's pytest plugin (no tests here)."""
from __future__ import annotations

import os
import subprocess
import sys
from importlib.metadata import entry_points
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLUGIN = "tools.pytest_plugin"


def plugin_args() -> list[str]:
    """`-p tools.pytest_plugin` when the installed towerlink does not register the plugin yet
    (an editable install older than the pytest11 entry point); nothing when it does (loading
    it twice would be an error)."""
    installed = any(ep.value == PLUGIN for ep in entry_points(group="pytest11"))
    return [] if installed else ["-p", PLUGIN]


def run_pytest(args: list[str], cwd: Path, timeout: float = 240.0, env: dict | None = None) -> subprocess.CompletedProcess:
    """pytest in a child process, as a user runs it (no towerlink conftest), with this tree
    first on the path; its output in .stdout."""
    e = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    e.update(env or {})
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *plugin_args(), *args],
                          cwd=cwd, env=e, capture_output=True, text=True, timeout=timeout)


def processes_mentioning(text: str) -> list[str]:
    """Command lines of the running processes that contain `text` (this process excluded)."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit() or int(d.name) == os.getpid():
            continue
        try:
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if text in cmd:
            found.append(f"{d.name}: {cmd[:200]}")
    return found


def run_group(args: list[str], timeout: float) -> tuple[int, str]:
    """Run a program in a process group of its own and kill the whole group afterwards
    (a MAVSDK 3.x script's mavsdk_server too, whatever happened); (exit code, output)."""
    import signal
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        out = "(timed out)"
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
    return proc.returncode, out
