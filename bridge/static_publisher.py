"""Ask a running bridge to add a static frame (``towerlink static-transform --publish``)."""
from __future__ import annotations

import time

from common.frames import TransformStamped
from common.mavlink.ids import TOWER_SYSID
from common.tf2_ros.wire import static_transform_message


def publish_static(url: str, ts: TransformStamped, timeout: float = 3.0, interval: float = 0.5,
                   source_system: int = TOWER_SYSID, signing_key: bytes | None = None) -> str:
    """Send `ts` to a bridge's tower port and wait for the bridge's verdict.

    UDP may lose the request, so it is repeated every `interval` wall seconds until
    the bridge answers with its STATUSTEXT ("static tf ... added" / "refused: ...").
    With `signing_key` the request is MAVLink 2 signed (a bridge started with
    --signing-key accepts nothing else). Returns the bridge's text; raises
    TimeoutError if nothing answered in `timeout`.
    """
    from common.mavlink.dialect import mavlink_connection

    conn = mavlink_connection(url, source_system=source_system, source_component=190)
    if signing_key:
        conn.setup_signing(signing_key, sign_outgoing=True)
    try:
        deadline = time.monotonic() + timeout
        next_send = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_send:
                conn.mav.send(static_transform_message(ts))
                next_send = time.monotonic() + interval
            msg = conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.1)
            if msg is not None and msg.text.startswith("static tf"):
                return msg.text
        raise TimeoutError(f"no bridge answered at {url} within {timeout:.1f} s")
    finally:
        conn.close()
