"""pytest fixtures shared by every test module.

`make test` runs the suite in two passes: everything not marked slow on two cores
(pytest-xdist, `-n 2 --dist loadfile`: a module's tests stay on one worker, so a module-scoped
fixture is built once), then the full-system tests (marked slow) one at a time, so no two
whole-system runs compete for the CPU (their figures, e.g. the rover's follow error, come from
processes that react on the wall clock unless they run in lockstep).
"""
from __future__ import annotations

import pytest

from support import Processes


@pytest.fixture
def processes():
    """Start child processes with processes.start([...]); all are stopped at teardown."""
    procs = Processes()
    try:
        yield procs
    finally:
        procs.stop_all()

