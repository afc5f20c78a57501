"""pytest fixtures and hooks shared by every test module.

`make test` runs the suite in three passes (pytest-xdist, `--dist loadfile
--no-loadscope-reorder`: a module's tests stay on one worker, so a module-scoped fixture is
built once; the modules are handed out longest first, see pytest_collection_modifyitems):
1. the tests not marked slow or alone, on four workers: most of them wait on worlds, sockets
   and timers rather than compute, so four workers keep two cores busy where two kept one.
2. the full-system tests (marked slow) but those marked alone, on two workers: they fly in
   lockstep or judge on the world's own (sim) clock, so the other worker's load changes none
   of their figures. They stay apart from pass 1: their flights fill the cores, and the
   clients of pass 1 (MAVSDK, MAVProxy, pymavlink's mavftp) give up on replies after wall
   seconds.
3. the tests marked alone, one at a time: whole systems whose processes react on the wall
   clock (not in lockstep), and wall-clock figures, which need the cores to themselves (beside
   pass 2 even at a lower CPU priority, MAVSDK's mission upload timed out twice in two runs).
`pytest -m slow` / `-m "not slow"` still pick either half.
"""
from __future__ import annotations

import collections
import signal

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
    # a run started in the background of a non-interactive shell (`make test &`, a script's
    # `cmd &`) has SIGINT ignored, and so would every program the tests start (an ignored signal
    # stays ignored across exec): the tests and the tools stop programs as Ctrl-C does, SIGINT
    # and then SIGKILL after a grace, and would wait out every grace (20 s for a sweep's run)
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    config.addinivalue_line(
        "markers", "alone: judged on the wall clock (a whole system not in lockstep, a wall-clock "
                   "figure): `make test` runs it with nothing beside it, after the parallel passes")


TEST_SECONDS = "towerlink/test_seconds"          # pytest's cache: each test's wall s, its last run
WORLD_FIXTURES = {"processes", "towerlink_sitl", "sitl", "shared_sitl", "mavproxy"}   # programs or a world
WORLD_TEST_S, OTHER_TEST_S = 8.0, 0.3               # the guess for a test no run has timed yet


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Modules in the order `make test` hands them to its workers (it passes xdist's
    --no-loadscope-reorder): the full-system (slow) ones first, then the others (for a run
    of both); each half longest first, a module's length the sum of its tests' seconds in their last run
    (pytest's cache), or, for a test not timed yet (a clean clone), a guess (one that starts
    programs or a world takes seconds). Longest first, no module of half a minute starts
    while the other workers are finishing. A stable sort, so a module's tests keep their
    order, and the same on every worker, as xdist requires."""
    cache = getattr(config, "cache", None)
    timed = cache.get(TEST_SECONDS, {}) if cache is not None else {}
    slow = {item.path for item in items if item.get_closest_marker("slow") is not None}
    seconds: collections.Counter = collections.Counter()
    for item in items:
        guess = WORLD_TEST_S if WORLD_FIXTURES & set(item.fixturenames) else OTHER_TEST_S
        seconds[item.path] += timed.get(item.nodeid, guess)
    items.sort(key=lambda item: (item.path not in slow, -seconds[item.path]))


_took: collections.Counter = collections.Counter()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    _took[report.nodeid] += report.duration        # setup, call and teardown


def pytest_sessionfinish(session: pytest.Session) -> None:
    """This run's tests' seconds into pytest's cache, for the next run's order (written by the
    process that saw every report: the one xdist's workers report to, or a run without them)."""
    cache = getattr(session.config, "cache", None)
    if cache is None or hasattr(session.config, "workerinput") or not _took:
        return
    cache.set(TEST_SECONDS, {**cache.get(TEST_SECONDS, {}), **{t: round(s, 2) for t, s in _took.items()}})
