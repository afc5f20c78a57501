"""Files written all-or-nothing: the bytes go to a staging copy, which replaces the target in
one rename when the writer closes.

ArduPilot's GCS_FTP writes in place (CreateFile opens O_WRONLY|O_CREAT|O_TRUNC), so a crash in
the middle of an upload leaves a cut file where a whole one was. Here the target keeps its
previous content until the upload is closed (TerminateSession, ResetSessions, a session taken
over or timed out: every close ArduPilot would make), then the staging copy is fsync'ed,
renamed over the target and the directory fsync'ed: after a crash the target is either the old
file or the new one, never a mix. What a client sees otherwise is ArduPilot's: the open fails
as the in-place open would (the target is opened O_WRONLY|O_CREAT first, so a new file appears
at once, empty; a directory, a missing parent or a read-only file give their errno), writes
land at their offsets, and OpenFileWO starts from the file's current content.

Staging copies live in a directory beside the root (never inside it, so no listing shows them
and no path reaches them); what a crash left there is removed when a server starts.
"""
from __future__ import annotations

import errno
import os
import shutil
import stat
import tempfile

from vehicle.files.durable import fsync_path


def staging_dir_for(root: bytes) -> bytes:
    """The staging directory of a root: a hidden sibling, on the same file system."""
    parent, name = os.path.split(root.rstrip(b"/"))
    return os.path.join(parent, b"." + name + b".partial")


def clear_staging(staging: bytes) -> None:
    """Remove what an interrupted upload left (the directory itself is kept or created)."""
    shutil.rmtree(staging, ignore_errors=True)
    os.makedirs(staging, exist_ok=True)


class StagedFile:
    """An open upload. `write(offset, data)` at any offset; `close()` puts it in place;
    `discard()` drops it. Raises OSError with the errno the failing call gave."""

    writable = True

    def __init__(self, target: bytes, staging: bytes, truncate: bool) -> None:
        # the in-place open ArduPilot makes, for its errors (non-blocking: a FIFO is ENXIO)
        os.close(os.open(target, os.O_WRONLY | os.O_CREAT | os.O_CLOEXEC | os.O_NONBLOCK, 0o644))
        if not stat.S_ISREG(os.stat(target).st_mode):
            raise OSError(errno.EINVAL, os.strerror(errno.EINVAL), os.fsdecode(target))
        self.target = target
        fd, self.path = tempfile.mkstemp(dir=staging, prefix=b"upload-")
        self.fd: int | None = fd
        try:
            if not truncate:
                with open(target, "rb") as src, os.fdopen(os.dup(fd), "wb") as dst:
                    shutil.copyfileobj(src, dst)
        except OSError:
            self.discard()
            raise

    def write(self, offset: int, data: bytes) -> int:
        return os.pwrite(self.fd, data, offset)

    def close(self) -> None:
        """fsync, rename over the target, fsync its directory."""
        if self.fd is None:
            return
        fd, self.fd = self.fd, None
        try:
            os.fchmod(fd, 0o644)
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.replace(self.path, self.target)
        except OSError:
            _unlink(self.path)
            raise
        fsync_path(os.path.dirname(self.target), directory=True)

    def discard(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        _unlink(self.path)


def _unlink(path: bytes) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass

