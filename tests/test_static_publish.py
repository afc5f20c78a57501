"""`towerlink static-transform --publish` adds a frame to a running bridge, live."""
from __future__ import annotations

import subprocess
import sys

from common.mavlink.dialect import mavlink_connection
from common.tf2_ros.wire import transform_from_message
from support import free_port, wait_until


def test_publish_adds_a_static_frame_the_bridge_then_streams(processes):
    port = free_port()
    processes.start(["towerlink", "bridge", "--tower", f"udpin:127.0.0.1:{port}",
                     "--drone", "none", "--rover", "none", "--no-follow", "-q"])
    tool = [sys.executable, "-m", "tools.cli", "static-transform", "1", "2", "0", "0.5", "0", "0",
            "world", "house", "--publish", f"udpout:127.0.0.1:{port}", "--timeout", "20"]
    out = subprocess.run(tool, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "static tf world->house added" in out.stdout

    # The bridge now streams the new edge (statics at 1 Hz) to its tower peers.
    conn = mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    try:
        def house():
            conn.mav.heartbeat_send(6, 8, 0, 0, 0)
            msg = conn.recv_match(type="TOWERLINK_TRANSFORM", blocking=True, timeout=0.5)
            if msg is not None:
                ts, static = transform_from_message(msg)
                if ts.child_frame_id == "house":
                    return ts, static
            return None
        ts, static = wait_until(house, timeout=20, what="TOWERLINK_TRANSFORM world->house")
        assert static and ts.frame_id == "world"
        assert list(ts.transform.translation) == [1.0, 2.0, 0.0]
    finally:
        conn.close()

    # A static edge into world (the bridge's root) is refused, and the tool says so with a non-zero status.
    tool[4:12] = ["0", "0", "0", "0", "0", "0", "house", "world"]
    refused = subprocess.run(tool, capture_output=True, text=True, timeout=60)
    assert refused.returncode == 1 and "refused" in refused.stdout
