"""fsync by path, for what must survive a crash of the machine (a file put in place, a log
closed): best effort, errors ignored (what could not be synced is still written)."""
from __future__ import annotations

import os


def fsync_path(path: str | bytes | os.PathLike, directory: bool = False) -> None:
    """Flush a file (or, `directory`, a directory's entries) to the disk."""
    try:
        fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
