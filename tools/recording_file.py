"""A recording named on the command line (a tlog, or a run's .mcap), checked before reading.

pymavlink opens any path that is not an existing file as a serial port, so a mistyped tlog
path would fail as "could not open port"; the tools check the path first and say what is
wrong with it.
"""
from __future__ import annotations

import os
from pathlib import Path


def require_recording(path: str | os.PathLike) -> Path:
    """``path`` as a Path if it names a readable file; else FileNotFoundError,
    IsADirectoryError or PermissionError whose message names the path."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{path}: file does not exist")
    if p.is_dir():
        raise IsADirectoryError(f"{path}: is a directory, not a tlog or .mcap recording")
    if not os.access(p, os.R_OK):
        raise PermissionError(f"{path}: not readable")
    return p
