"""Where a simulated vehicle keeps its files: one directory per vehicle, the "/" its MAVFTP
server serves (as ArduPilot SITL serves its working directory) and the parent of its
DataFlash logs.

Layout (one world, one state dir):

    <state_dir>/vehicles/<index>/         the vehicle's root (MAVFTP "/"), index = world index
    <state_dir>/vehicles/<index>/logs/    its logs (ArduPilot SITL: HAL_BOARD_LOG_DIRECTORY "logs",
                                          relative to the working directory; MAVFTP also names it
                                          "@MAV_LOG")

A world without a state dir (WorldConfig.state_dir None: nothing persisted) has no such
directory; what serves files then uses a temporary one of its own, removed when it closes.
"""
from __future__ import annotations

import os
from pathlib import Path

VEHICLES_DIR = "vehicles"
LOGS_DIR = "logs"


def vehicle_root(state_dir: str | os.PathLike, index: int) -> Path:
    """The root directory of the world's vehicle `index` (not created here)."""
    return Path(state_dir) / VEHICLES_DIR / str(int(index))


def logs_dir(root: str | os.PathLike) -> Path:
    """The log directory inside a vehicle root (not created here)."""
    return Path(root) / LOGS_DIR
