"""The onboard logs of one world: the writer thread every vehicle's log hands its bytes to,
and where each vehicle keeps its logs, `<state_dir>/vehicles/<index>/logs/`
(vehicle/vehicle_root.py).

A world without a state dir (nothing persisted) logs into a temporary folder of its own,
removed when the world closes (or, for a world that never ran its loop, when it is
garbage-collected or the process ends): its logs can be downloaded while it runs.
"""
from __future__ import annotations

import shutil
import tempfile
import weakref
from collections.abc import Callable
from pathlib import Path

from vehicle.logs.vehicle_log import VehicleLog
from vehicle.logs.writer import LogWriter
from vehicle.vehicle_root import logs_dir, vehicle_root


class WorldLogs:
    """One LogWriter and the logs' root for a world; `for_vehicle` builds each vehicle's log."""

    def __init__(self, state_dir: str | None) -> None:
        self.writer = LogWriter()
        self.temporary = state_dir is None
        self.root = Path(state_dir) if state_dir else Path(tempfile.mkdtemp(prefix="towerlink-logs-"))
        self._cleanup = (weakref.finalize(self, shutil.rmtree, str(self.root), ignore_errors=True)
                         if self.temporary else None)

    def folder(self, index: int) -> Path:
        """Vehicle `index`'s log folder."""
        return logs_dir(vehicle_root(self.root, index))

    def for_vehicle(self, kind: str, index: int, clock: Callable[[], float], unix_start_us: int,
                    firmware: str, ap_rate: float) -> VehicleLog:
        """The log of world vehicle `index` ("copter" / "rover"); its 10 Hz samples fall on the
        tick its index picks, so a big world's sampling is spread over the ticks."""
        return VehicleLog(kind, self.folder(index), self.writer, clock, unix_start_us, firmware,
                          phase=index, ap_rate=ap_rate)

    def close(self) -> None:
        """Write what is queued (the vehicles' logs closed first), end the writer thread,
        remove a temporary folder."""
        self.writer.stop()
        if self._cleanup is not None:
            self._cleanup()
