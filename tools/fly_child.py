"""A helper child of `towerlink fly`, forked when the run starts and busy at a lower CPU priority while it flies.

The drawings' worker (tools.fly_drawings) and the live recording (tools.fly_recorder) are such
children: they use what the lockstep chain leaves of the cores during the flight, so that less
is left for after it. :class:`ForkedHelper` forks one (before the launcher starts any thread),
hands it jobs through a pipe, waits for it and always stops and reaps it (:meth:`close`, also on
failure or Ctrl-C; the child ignores SIGINT, which is the launcher's to handle, and gets SIGTERM
if the launcher dies outright).
"""
from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable

#: the child's niceness while the run flies: it takes what the lockstep chain leaves idle
HELPER_NICE = 10
#: wall s the launcher waits for a child's work before it stops it and goes on without it
HELPER_TIMEOUT = 120.0


class ForkedHelper:
    """`main(conn)` in a forked child; the parent sends it jobs (:meth:`send`)."""

    def __init__(self, name: str, main: Callable) -> None:
        self.name = name
        self._main = main
        self._conn = None
        self._child: multiprocessing.process.BaseProcess | None = None

    @staticmethod
    def available() -> bool:
        return "fork" in multiprocessing.get_all_start_methods()

    @staticmethod
    def cpus() -> int:
        """The CPUs this process may run on (its affinity, where the system says)."""
        try:
            return len(os.sched_getaffinity(0))
        except AttributeError:  # pragma: no cover - no affinity call (not Linux)
            return os.cpu_count() or 1

    def start(self) -> None:
        from tools.procs import die_with_parent
        ctx = multiprocessing.get_context("fork")
        there, here = ctx.Pipe(duplex=False)        # (receiving end, sending end)
        self._child = ctx.Process(target=_child_main, args=(self._main, there, die_with_parent()),
                                  name=self.name, daemon=True)
        self._child.start()
        there.close()
        self._conn = here

    def send(self, job) -> None:
        """Hand the child a job (dropped if the child is gone: its work is then left out)."""
        try:
            self._conn.send(job)
        except (OSError, ValueError, AttributeError):
            pass

    def wait(self) -> None:
        """Wait for the child to end (at most HELPER_TIMEOUT), then :meth:`close`."""
        if self._child is not None:
            self._child.join(HELPER_TIMEOUT)
        self.close()

    def close(self) -> None:
        """Stop the child if it still runs and reap it; idempotent."""
        if self._conn is not None:
            self._conn.close()
            self._conn = None
        child, self._child = self._child, None
        if child is None:
            return
        if child.is_alive():
            child.terminate()
            child.join(5.0)
            if child.is_alive():
                child.kill()
        child.join()


def _child_main(main: Callable, conn, with_parent) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # a Ctrl-C is the launcher's: it stops us
    if with_parent is not None:
        with_parent()       # SIGTERM when the launcher dies outright
    main(conn)


class SubHelper:
    """`main(conn)` in a child of a helper child, forked by it (with os.fork: multiprocessing lets no
    daemon process have children), sharing what the helper imported; it ends with the helper
    (tools.procs.die_with_parent) and ignores SIGINT as the helper does. The helper sends it jobs
    (:meth:`send`) and reaps it (:meth:`wait`)."""

    def __init__(self, main: Callable) -> None:
        from tools.procs import die_with_parent
        there, self._conn = multiprocessing.Pipe(duplex=False)
        with_parent = die_with_parent()
        self.pid = os.fork()
        if self.pid == 0:           # the sub-helper: never back into the helper's code
            code = 1
            try:
                self._conn.close()
                if with_parent is not None:
                    with_parent()
                main(there)
                code = 0
            finally:
                os._exit(code)
        there.close()

    def send(self, job) -> None:
        """Hand it a job (dropped if it is gone)."""
        try:
            self._conn.send(job)
        except (OSError, ValueError):
            pass

    def wait(self) -> None:
        """Close its pipe and wait for it to end."""
        self._conn.close()
        try:
            os.waitpid(self.pid, 0)
        except ChildProcessError:
            pass


class Priority:
    """Lower this process's CPU priority while the run flies; back to where it was when it matters."""

    def __init__(self) -> None:
        self.base = os.getpriority(os.PRIO_PROCESS, 0)
        try:
            os.setpriority(os.PRIO_PROCESS, 0, self.base + HELPER_NICE)
        except OSError:
            pass

    def restore(self) -> None:
        """Back to the launcher's priority (where lowering one's niceness is not allowed: stays low)."""
        try:
            os.setpriority(os.PRIO_PROCESS, 0, self.base)
        except OSError:
            pass
