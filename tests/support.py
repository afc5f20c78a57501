"""Shared test helpers: free ports, condition waits, managed child processes.

Tests wait on conditions with deadlines, never on fixed sleeps.
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from typing import TypeVar

from common.ports import free_port, free_ports  # noqa: F401  (the tests import them from here)

T = TypeVar("T")


def udp_listener(timeout: float = 5.0) -> tuple[socket.socket, int]:
    """A UDP socket bound now to a free port on 127.0.0.1 (no pick-then-bind race), with a
    receive timeout (s): a fake peer's end. Returns (socket, port); the caller closes it."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(timeout)
    return s, s.getsockname()[1]


def wait_until(cond: Callable[[], T], timeout: float, what: str = "condition",
               interval: float = 0.01) -> T:
    """Poll `cond` until it returns a truthy value or `timeout` wall seconds pass.

    Returns the truthy value; raises AssertionError naming `what` on timeout.
    """
    deadline = time.monotonic() + timeout
    while True:
        value = cond()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:.1f} s waiting for {what}")
        time.sleep(interval)  # poll


class Processes:
    """Child processes started by a test; all stopped at teardown, whatever happens."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen] = []

    def start(self, args: list[str], **kw) -> subprocess.Popen:
        """Start `python -m towerlink-ish args` style commands; args[0] may be 'towerlink'."""
        if args and args[0] == "towerlink":
            args = [sys.executable, "-m", "tools.cli", *args[1:]]
        kw.setdefault("stdout", subprocess.PIPE)
        kw.setdefault("stderr", subprocess.STDOUT)
        kw.setdefault("text", True)
        proc = subprocess.Popen(args, start_new_session=True, **kw)
        self.procs.append(proc)
        return proc

    def stop(self, proc: subprocess.Popen, timeout: float = 5.0) -> None:
        if proc.poll() is None:
            try:
                os.killpg(proc.pid, signal.SIGTERM)
                proc.wait(timeout=timeout)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                try:
                    os.killpg(proc.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                proc.wait(timeout=timeout)

    def stop_all(self) -> None:
        for proc in reversed(self.procs):
            self.stop(proc)
