"""pytest fixtures shared by every test module."""
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


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """`make test` runs on two cores (pytest-xdist, --dist loadgroup): a module's tests stay
    together on one worker (module-scoped fixtures are built once), and the full-system tests
    marked slow share one group, so no two whole-system runs compete for the CPU (their
    figures, e.g. the rover's follow error, come from processes on the wall clock)."""
    for item in items:
        group = "system" if item.get_closest_marker("slow") else item.module.__name__
        item.add_marker(pytest.mark.xdist_group(group))
