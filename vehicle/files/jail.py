"""A path jail: every path a client names is resolved inside one root directory, or refused.

ArduPilot SITL maps "/" to its working directory and strips one leading "/" (AP_Filesystem_posix
map_filename), and leaves ".." to the user ("Users can still escape with .. if they want to").
Here nothing leaves the root:

- leading "/", empty and "." components are dropped ("/logs", "logs/" and "./logs" are one
  place); ".." climbs lexically and a ".." above the root is refused;
- symbolic links are followed as the kernel follows them (os.path.realpath) and the result
  must lie inside the root's own real path, else refused - a link pointing out of the root,
  dangling or not, is never stat'ed, opened or listed;
- a NUL byte is refused; a component longer than NAME_MAX (255 bytes) is ENAMETOOLONG, as
  the kernel would answer, without a system call.

A refused path raises FileNotFoundError (ENOENT): outside the root nothing exists, and the
client gets the answer ArduPilot gives for a missing file (FileNotFound). The check is made
when a request arrives; a symlink swapped in by a local process between the check and the
system call is not guarded against (MAVFTP itself cannot create links).

Paths are bytes throughout (os.fsencode'd names, any encoding the client sends).
"""
from __future__ import annotations

import errno
import os
from pathlib import Path

NAME_MAX = 255


def _refused(path: bytes) -> FileNotFoundError:
    return FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), os.fsdecode(path))


class PathJail:
    def __init__(self, root: str | os.PathLike) -> None:
        """root: an existing directory; its real path is the boundary."""
        self.root = os.fsencode(os.path.realpath(root))

    def components(self, path: bytes) -> list[bytes]:
        """The path's components below the root after the lexical walk ("" is the root)."""
        if b"\0" in path:
            raise _refused(path)
        out: list[bytes] = []
        for part in path.split(b"/"):
            if len(part) > NAME_MAX:
                raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG), os.fsdecode(path))
            if part in (b"", b"."):
                continue
            if part == b"..":
                if not out:
                    raise _refused(path)
                out.pop()
                continue
            out.append(part)
        return out

    def resolve(self, path: bytes, follow: bool = True) -> bytes:
        """The absolute path (bytes) `path` names inside the root. follow=False keeps a last
        component that is a symlink as the link itself (remove, rename, mkdir act on the entry);
        its directory must still resolve inside. Raises FileNotFoundError when refused."""
        parts = self.components(path)
        joined = os.path.join(self.root, *parts) if parts else self.root
        if follow or not parts:
            real = os.path.realpath(joined)
        else:
            real = os.path.join(os.path.realpath(os.path.dirname(joined)), parts[-1])
        if not self.inside(real):
            raise _refused(path)
        return real

    def inside(self, real: bytes) -> bool:
        """Whether a real (symlink-free) absolute path is the root or below it."""
        return real == self.root or real.startswith(self.root.rstrip(b"/") + b"/")

    def is_root(self, real: bytes) -> bool:
        return real == self.root

    def entry_target_inside(self, directory: bytes, name: bytes) -> bool:
        """For a listing: whether entry `name` of the real directory `directory` resolves
        (following links) inside the root."""
        return self.inside(os.path.realpath(os.path.join(directory, name)))


def ensure_dir(path: str | os.PathLike) -> Path:
    """Create a directory (and its parents) if missing; returns it as a Path."""
    p = Path(path)
    p.mkdir(parents=True, exist_ok=True)
    return p
