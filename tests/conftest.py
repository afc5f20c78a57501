"""pytest fixtures shared by every test module.

`make test` runs the whole suite in one pytest on two cores (pytest-xdist, `-n 2 --dist
loadfile`: a module's tests stay on one worker, so a module-scoped fixture is built once).
The full-system modules (marked slow: whole worlds over loopback, tens of seconds each) are
handed out first (see pytest_collection_modifyitems), so the two workers share them and the short modules fill in behind
instead of one long module running alone at the end. Their figures do not depend on the
other worker's load: they fly in lockstep, or judge on the world's own (sim) clock.
`pytest -m slow` / `-m "not slow"` still pick either half.
"""
from __future__ import annotations

import collections

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


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Modules in the order `make test` hands them to its workers (it passes xdist's
    --no-loadscope-reorder): the full-system (slow) ones first, then the others, each half
    by number of tests, most first (xdist's own reorder); a stable sort, so a module's tests
    keep their order, and the same on every worker, as xdist requires."""
    slow = {item.path for item in items if item.get_closest_marker("slow") is not None}
    count = collections.Counter(item.path for item in items)
    items.sort(key=lambda item: (item.path not in slow, -count[item.path]))
