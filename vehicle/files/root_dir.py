"""The directory a vehicle's file server serves: the vehicle's root in the world's state dir
(vehicle/vehicle_root.py), or, for a world that persists nothing, a temporary directory made
on first use and removed when the vehicle's link closes."""
from __future__ import annotations

import os
import tempfile
from pathlib import Path


class RootDir:
    def __init__(self, path: str | os.PathLike | None) -> None:
        """path: the vehicle's root, None for a temporary one."""
        self._given = Path(path) if path is not None else None
        self._temp: tempfile.TemporaryDirectory | None = None

    def path(self) -> Path:
        if self._given is not None:
            return self._given
        if self._temp is None:
            self._temp = tempfile.TemporaryDirectory(prefix="towerlink-vehicle-")
        return Path(self._temp.name) / "root"

    def close(self) -> None:
        """Remove the temporary directory, if one was made (a given root stays)."""
        if self._temp is not None:
            self._temp.cleanup()
            self._temp = None
