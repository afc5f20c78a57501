"""Opening a client's pymavlink connection, as a GCS (towerlink dialect when it is installed)."""
from __future__ import annotations

from typing import Any

from gcs.client.mav import mavutil


def open_connection(conn: str, source_system: int, source_component: int) -> Any:
    """Open `conn` (udpout:H:P, udpin:H:P, tcp:H:P); with the towerlink dialect when it is installed."""
    try:  # the project dialect decodes the transform stream; optional for a GCS
        from common.mavlink import dialect as _dialect  # type: ignore
        opener = getattr(_dialect, "mavlink_connection", None) or getattr(_dialect, "connect", None)
        if opener is not None:
            return opener(conn, source_system=source_system, source_component=source_component)
    except Exception:  # noqa: BLE001 - fall back to plain ardupilotmega
        pass
    return mavutil.mavlink_connection(conn, source_system=source_system,
                                      source_component=source_component,
                                      dialect="ardupilotmega", autoreconnect=True)


def open_dialect_connection(conn: str, source_system: int, source_component: int) -> Any:
    """Open `conn` with the towerlink dialect, required (lockstep speaks TOWERLINK_LOCKSTEP)."""
    from common.mavlink.dialect import mavlink_connection
    return mavlink_connection(conn, source_system=source_system, source_component=source_component,
                              autoreconnect=True)
