"""The child processes of a `towerlink fly` run, each logged to RUN/<name>.log.

Every child runs in a session of its own (a Ctrl-C at the terminal reaches only the launcher,
which then stops them in order) and ends with the launcher if it is killed outright
(tools.procs.die_with_parent). The log starts with the command line, the signing key masked.
"""
from __future__ import annotations

import os
import select
import shlex
import signal
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

from common.mavlink.signing import masked_argv
from tools.procs import die_with_parent


def signal_group(p: subprocess.Popen, sig: int) -> None:
    """Send `sig` to the process group `p` leads (its whole session); gone already is fine."""
    try:
        os.killpg(p.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


class ProcessGroup:
    """Starts named children with their output in `log_dir`/<name>.log; stops them."""

    def __init__(self, log_dir: Path) -> None:
        self.dir = Path(log_dir)
        self.procs: dict[str, subprocess.Popen] = {}
        self.logs: dict[str, object] = {}
        self._told: dict[str, subprocess.Popen] = {}     # name -> the process already asked to stop

    def start(self, name: str, args: list[str], on_line: Callable[[str], None] | None = None,
              env: dict[str, str] | None = None) -> subprocess.Popen:
        """Start `args` as `name` (`env`: variables added to this process's environment). With
        `on_line`, its output is read here, line by line: each line is logged, then handed to
        on_line (without its newline)."""
        log = open(self.dir / f"{name}.log", "a")
        self.logs.setdefault(name, log)
        log.write(f"$ {shlex.join(masked_argv(args))}\n")     # the signing key never in clear
        log.flush()
        env = dict(os.environ, PYTHONUNBUFFERED="1", **(env or {}))
        if on_line is not None:
            p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                 start_new_session=True, env=env, bufsize=1, preexec_fn=die_with_parent())
            threading.Thread(target=self._read, args=(p, log, on_line), daemon=True).start()
        else:
            # stdin: none reads it, and a world started through `ssh -tt` would take the terminal raw
            p = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, env=env,
                                 stdin=subprocess.DEVNULL, preexec_fn=die_with_parent())
        self.procs[name] = p
        return p

    @staticmethod
    def _read(p: subprocess.Popen, log, on_line: Callable[[str], None]) -> None:
        for line in p.stdout:
            log.write(line)
            log.flush()
            on_line(line.rstrip("\n"))

    def alive(self) -> dict[str, bool]:
        """name -> still running."""
        return {k: p.poll() is None for k, p in self.procs.items()}

    def exited(self, name: str) -> int | None:
        """The exit status of `name`; None while it runs or if it was never started."""
        p = self.procs.get(name)
        return None if p is None else p.poll()

    def wait(self, name: str, timeout: float) -> int | None:
        """`name`'s exit status once it ends, None if it runs on for `timeout` s. Told by the
        kernel the moment it ends (a pidfd) where it can, not found by polling."""
        p = self.procs[name]
        if p.poll() is not None:            # reaped: its pid may be another process's by now
            return p.returncode
        try:
            fd = os.pidfd_open(p.pid)
        except (AttributeError, OSError):   # not Linux >= 5.3, or already reaped: poll
            fd = None
        if fd is not None:
            try:
                select.select([fd], [], [], max(0.0, timeout))
            finally:
                os.close(fd)
        try:
            return p.wait(0.0 if fd is not None else max(0.0, timeout))
        except subprocess.TimeoutExpired:
            return None

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Signal `name`'s session and wait for it (no goodbye with SIGKILL)."""
        p = self.procs.get(name)
        if p is not None and p.poll() is None:
            signal_group(p, sig)
            p.wait(5)

    def tell_to_stop(self, name: str, sig: int) -> None:
        """Signal `name`'s session once, without waiting (:meth:`stop` then only waits): a second
        signal could reach a process past its own handler, in its last steps."""
        p = self.procs.get(name)
        if p is None or p.poll() is not None or self._told.get(name) is p:
            return
        self._told[name] = p
        signal_group(p, sig)

    def stop(self, name: str, sig: int, timeout: float = 5.0) -> None:
        """Signal `name`'s session (unless :meth:`tell_to_stop` did), wait `timeout` s, then kill it."""
        p = self.procs.get(name)
        if p is None or p.poll() is not None:
            return
        self.tell_to_stop(name, sig)
        try:
            p.wait(timeout)
        except subprocess.TimeoutExpired:
            signal_group(p, signal.SIGKILL)
            p.wait(timeout)

    def close_logs(self) -> None:
        for log in self.logs.values():
            try:
                log.close()
            except Exception:  # noqa: BLE001
                pass
