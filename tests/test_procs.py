"""tools.procs.die_with_parent: a child started with it ends when its parent is SIGKILLed."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading

from support import wait_until
from tools.procs import die_with_parent

# the body of a parent process the test SIGKILLs; both processes pause until a signal ends them
PARENT = textwrap.dedent("""
    import signal, subprocess, sys
    from tools.procs import die_with_parent
    child = subprocess.Popen([sys.executable, "-c", "import signal; signal.pause()"],
                             start_new_session=True, preexec_fn=die_with_parent())
    print(child.pid, flush=True)
    signal.pause()          # until SIGKILLed by the test
""")


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except FileNotFoundError:
        return False


def test_child_in_its_own_session_ends_when_the_parent_is_killed():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    parent = subprocess.Popen([sys.executable, "-c", PARENT], stdout=subprocess.PIPE, text=True,
                              env=dict(os.environ, PYTHONPATH=root))
    child = None
    try:
        child = int(parent.stdout.readline())
        assert _alive(child)
        parent.kill()                    # no goodbye: the parent cannot stop its child itself
        parent.wait(10)
        wait_until(lambda: not _alive(child), 10, "the orphaned child to end")
    finally:
        parent.kill()
        parent.stdout.close()
        if child is not None and _alive(child):
            os.kill(child, signal.SIGKILL)


def test_no_death_signal_from_a_thread_that_would_end_first():
    got = []
    t = threading.Thread(target=lambda: got.append(die_with_parent()))
    t.start()
    t.join()
    assert got == [None] and callable(die_with_parent())
