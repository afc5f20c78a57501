"""`towerlink sitl` stops in order on SIGTERM: with a TCP client connected (as MAVProxy or
QGroundControl on 5760 would be) it exits 0, prints its stats line and no asyncio traceback
(the TCP server and its clients are closed before the event loop ends)."""
from __future__ import annotations

import os
import signal

import pytest

from support import wait_until
from test_sitl_support import Sitl, connect


@pytest.mark.timeout(60)
def test_sigterm_with_a_tcp_client_connected_exits_cleanly(processes, tmp_path):
    sitl = Sitl(processes, tmp_path, drones=1, rovers=0, speedup=1)
    m = connect(sitl.tcp[0], tcp=True)            # a TCP client, a HEARTBEAT received
    try:
        os.killpg(sitl.proc.pid, signal.SIGTERM)
        assert sitl.proc.wait(timeout=20) == 0
        wait_until(lambda: "stats:" in sitl.output(), 5, "the stats line")
    finally:
        m.close()
    out = sitl.output()
    assert "Traceback" not in out and "Exception in callback" not in out, out[-3000:]
