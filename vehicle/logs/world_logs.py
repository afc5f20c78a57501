"""The onboard logs of one world: the one writer thread every vehicle's log hands its bytes
to (vehicle/logs/writer.py), and each vehicle's log built on it.

Where a vehicle keeps its logs is its root's `logs/` (vehicle/vehicle_root.py: the root
MAVFTP serves, `<state_dir>/vehicles/<index>/`, or, in a world that persists nothing, the
vehicle's temporary root, removed when its link closes): the caller says, as a function
called when the first log opens, so a vehicle that never logs makes no folder.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from vehicle.logs.vehicle_log import VehicleLog
from vehicle.logs.writer import LogWriter


class WorldLogs:
    """One LogWriter for a world; `for_vehicle` builds a vehicle's log on it."""

    def __init__(self) -> None:
        self.writer = LogWriter()

    def for_vehicle(self, kind: str, folder: Callable[[], Path], clock: Callable[[], float],
                    unix_start_us: int, banner: Callable[[], Sequence[str]], phase: int,
                    ap_rate: float = 50.0) -> VehicleLog:
        """The log of a vehicle ("copter" / "rover") kept in folder(), each opening with the
        MSG lines banner() gives (firmware string, system id, frame); its 10 Hz samples
        fall on the autopilot tick `phase` picks (vehicles of a big world spread theirs)."""
        return VehicleLog(kind, folder, self.writer, clock, unix_start_us, banner, phase=phase, ap_rate=ap_rate)

    def close(self) -> None:
        """Write what is queued (the vehicles' logs closed first) and end the writer thread."""
        self.writer.stop()
