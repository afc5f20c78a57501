"""pytest fixtures and hooks shared by every test module.

`make test` runs the suite in two passes:
1. everything not marked `alone`, on four pytest-xdist workers (`-n 4 --dist loadfile
   --no-loadscope-reorder`: a module's tests stay on one worker, so a module-scoped fixture is
   built once). Most tests wait on worlds, sockets and timers rather than compute, so four
   workers keep two cores busy where two workers kept about one. The full-system modules
   (marked slow) are handed out first (pytest_collection_modifyitems), so the short modules
   fill in behind them instead of one long module running alone at the end. Their figures do
   not depend on the other workers' load: they fly in lockstep, or judge on the world's own
   (sim) clock.
2. the tests marked `alone`, one at a time: whole systems whose processes react on the wall
   clock (not in lockstep), so what they judge depends on having the cores to themselves.
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



def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers", "alone: a whole system on the wall clock (not lockstep): `make test` runs it with "
                   "nothing beside it, after the parallel pass")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Modules in the order `make test` hands them to its workers (it passes xdist's
    --no-loadscope-reorder): the full-system (slow) ones first, then the others, each half
    by number of tests, most first (xdist's own reorder); a stable sort, so a module's tests
    keep their order, and the same on every worker, as xdist requires."""
    slow = {item.path for item in items if item.get_closest_marker("slow") is not None}
    count = collections.Counter(item.path for item in items)
    items.sort(key=lambda item: (item.path not in slow, -count[item.path]))
