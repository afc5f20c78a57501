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
