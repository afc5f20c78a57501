"""Child processes that end with their parent.

tools start worlds, bridges and towers in sessions of their own (so a Ctrl-C at the terminal
reaches only the parent, which then stops them in order). A parent killed outright (SIGKILL, as
by a test runner's hard timeout or the OOM killer) cannot stop them, and they would run on,
holding ports. :func:`die_with_parent` is a ``preexec_fn`` that asks Linux to send the child a
signal when its parent goes (prctl PR_SET_PDEATHSIG).
"""
from __future__ import annotations

import os
import signal
import threading
from typing import Callable

PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGTERM) -> Callable[[], None] | None:
    """A ``preexec_fn`` for subprocess.Popen: the child gets `sig` when this parent dies.

    Linux ties the death signal to the thread that forked, not the process, so a child
    started from any other thread than the main one would be signalled when that thread
    ends: returns None there (no death signal). Best effort elsewhere: a system without
    prctl starts the child without one."""
    if threading.current_thread() is not threading.main_thread():
        return None
    parent = os.getpid()

    def preexec() -> None:
        try:
            import ctypes
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, sig)
        except Exception:  # noqa: BLE001 - no prctl (not Linux): no death signal
            return
        if os.getppid() != parent:      # the parent died before prctl took effect
            os.kill(os.getpid(), sig)

    return preexec
