"""towerlink's pytest plugin (installed with towerlink: the ``pytest11`` entry point, so a
test needs no conftest): the ``towerlink_sitl`` fixture, the ``towerlink`` marker and the
``--towerlink-*`` options. docs/testing.md is the guide.

    import pytest
    from pymavlink import mavutil

    @pytest.mark.towerlink(drones=1, speedup="max")
    def test_arm(towerlink_sitl):
        m = mavutil.mavlink_connection(towerlink_sitl.connection(0))
        m.wait_heartbeat()
        m.arducopter_arm()
        towerlink_sitl.wait_for(lambda: towerlink_sitl.vehicle(0).armed, sim_timeout=5)

Each test gets its own world on ports free at that moment (a new set when another process,
e.g. a pytest-xdist worker, took one first), stopped at teardown with nothing left running.
A failing test keeps the world's tlog and a track plot under its tmp_path, and the failure
report names them (a "towerlink" section).
"""
from __future__ import annotations

import pytest

from tools.sitl_spec import MARKER, MARKER_HELP

_SITL = pytest.StashKey[object]()
_FAILED = pytest.StashKey[bool]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("towerlink", "towerlink SITL worlds (the towerlink_sitl fixture)")
    group.addoption("--towerlink-speedup", metavar="N|max", default=None,
                    help="run every towerlink world at N sim s per wall s, or 'max' (overrides the markers)")
    group.addoption("--towerlink-mode", choices=("thread", "subprocess"), default=None,
                    help="where the worlds run: a thread of the test's process (the markers' default) "
                         "or a process each (overrides the markers)")
    group.addoption("--towerlink-keep-logs", action="store_true", default=False,
                    help="keep every test's world tlog and track plot under its tmp_path, not only a failing one's")


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", MARKER_HELP)


@pytest.fixture
def towerlink_sitl(request: pytest.FixtureRequest, tmp_path):
    """A running towerlink world (tools.sitl_fixture.TowerlinkSitl), configured by the test's
    ``@pytest.mark.towerlink(...)`` and the run's ``--towerlink-*`` options."""
    from tools.sitl_fixture import TowerlinkSitl
    from tools.sitl_spec import SpecError, make_spec
    marker = request.node.get_closest_marker(MARKER)
    opt = request.config.getoption
    try:
        spec = make_spec(marker.kwargs if marker else {}, speedup=opt("--towerlink-speedup"),
                         mode=opt("--towerlink-mode"), keep_logs=opt("--towerlink-keep-logs"))
    except SpecError as exc:
        pytest.fail(str(exc), pytrace=False)
    sitl = TowerlinkSitl(spec, tmp_path / "towerlink")
    sitl.start()
    request.node.stash[_SITL] = sitl
    try:
        yield sitl
    finally:
        del request.node.stash[_SITL]
        failed = request.node.stash.get(_FAILED, False)
        if spec.keep_logs and not failed:
            sitl.artefacts(request.node.nodeid)          # a failing test's are drawn already
        sitl.stop(keep_logs=spec.keep_logs or failed)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """A failing test's report gets a "towerlink" section: where its tlog and track plot are."""
    outcome = yield
    report = outcome.get_result()
    sitl = item.stash.get(_SITL, None)
    if sitl is not None and report.failed and report.when == "call":
        item.stash[_FAILED] = True
        report.sections.append(("towerlink", sitl.artefacts(item.nodeid)))
