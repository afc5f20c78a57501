"""A vehicle's file tree as ArduPilot's AP_Filesystem shows it over MAVFTP (SITL): the root
directory (PathJail: nothing outside it is reachable) plus the "@" virtual directories.

- "@PARAM/param.pck" (and any other virtual file given): read-only bytes made when opened
  ("?withdefaults=1" asks for defaults too); ArduPilot's param backend has no opendir, so
  "@PARAM" is not listed and cannot be listed.
- "@MAV_LOG": ArduPilot's alias for the log directory (logs/ in SITL's working directory),
  listed in the root when that directory exists.
- "@SYS": ArduPilot's system-information directory (vehicle/files/sys_dir.py): listed, its
  files read (OpenFileRO's ACK gives the size stat gives, as GCS_FTP does), read-only.
- "@ROMFS", "@MISSION": ArduPilot's other virtual trees, not served here: they stay virtual
  (FileNotFound to read, read-only to write) rather than becoming real directories.

The root's listing is the root directory's entries followed by the "@" directories
AP_Filesystem::readdir appends after the local backend's last entry: each backend whose
opendir("") succeeds, in its table's order (@ROMFS, @PARAM, @SYS, @MISSION, @MAV_LOG), typed
as directories. Here that is "@SYS", then "@MAV_LOG" when the log directory exists (@PARAM
and @MISSION have no opendir; SITL's embedded @ROMFS holds ArduPilot's model and location
files, which a towerlink vehicle does not have, so it is not listed).

Every method raises OSError with the errno the failing call gave (or the jail's ENOENT);
writes to a virtual path are EROFS. Listing entries are ArduPilot's gen_dir_entry strings
without their NUL: b"F<name>\\t<size>" for files (and symlinks, sized by their target),
b"D<name>" for directories, other types skipped; "." and ".." first, as POSIX readdir gives
them to SITL, then the entries by name.
"""
from __future__ import annotations

import errno
import os
import zlib
from collections.abc import Callable, Mapping

from vehicle.files.jail import PathJail, ensure_dir
from vehicle.files.staged import StagedFile, clear_staging, staging_dir_for
from vehicle.files.sys_dir import SYS, SysDir
from vehicle.vehicle_root import LOGS_DIR

MAV_LOG = b"@MAV_LOG"
VIRTUAL_DIRS = (b"@PARAM", SYS, b"@ROMFS", b"@MISSION")


class BytesFile:
    """A virtual file opened for reading: its bytes as they were at open; `size` is what
    stat said (@SYS's files say more than they hold)."""
    writable = False

    def __init__(self, content: bytes, size: int | None = None) -> None:
        self.content = content
        self.size = len(content) if size is None else size

    def read(self, offset: int, n: int) -> bytes:
        return self.content[offset:offset + n]

    def close(self) -> None:
        pass


class DiskFile:
    """A real file opened for reading (read where it stands: a growing log grows). Opened
    non-blocking: a FIFO someone left in the root gives EAGAIN instead of hanging the link."""
    writable = False

    def __init__(self, path: bytes) -> None:
        self.fd: int | None = os.open(path, os.O_RDONLY | os.O_CLOEXEC | os.O_NONBLOCK)
        self.size = os.fstat(self.fd).st_size

    def read(self, offset: int, n: int) -> bytes:
        return os.pread(self.fd, n, offset)

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def ap_crc32(chunks, crc: int = 0) -> int:
    """ArduPilot's crc_crc32: the reflected IEEE table from seed 0 without zlib's inversions."""
    for chunk in chunks:
        crc = zlib.crc32(chunk, crc ^ 0xFFFFFFFF) ^ 0xFFFFFFFF
    return crc


def _err(code: int, path: bytes = b"") -> OSError:
    return OSError(code, os.strerror(code), os.fsdecode(path))


class VehicleFiles:
    def __init__(self, root: str | os.PathLike | None,
                 virtual: Mapping[str, Callable[[bool], bytes]] | None = None,
                 sys_dir: SysDir | None = None) -> None:
        """root: the vehicle's directory (created if missing), None for no file system (only
        the virtual files, as when the directory cannot be made); virtual: path
        ("@PARAM/param.pck") -> content(with_defaults); sys_dir: @SYS (one without ports
        when not given)."""
        self.virtual = {os.fsencode(k): v for k, v in (virtual or {}).items()}
        self.sys = sys_dir if sys_dir is not None else SysDir()
        self.jail = self.staging = None
        if root is None:
            return
        try:
            jail = PathJail(ensure_dir(root))
            self.staging = staging_dir_for(jail.root)
            clear_staging(self.staging)
        except OSError:
            return                  # a directory that cannot be made or used: the virtual files only
        self.jail = jail

    # ----- routing ----------------------------------------------------------------------------
    def _local(self, path: bytes, follow: bool = True) -> bytes:
        """The real path of a path on the local file system (@MAV_LOG is logs/); ENOENT for a
        virtual one, for any without a file system, and for one the jail refuses."""
        p = path.lstrip(b"/")
        first, _, rest = p.partition(b"/")
        if self.jail is None or first in VIRTUAL_DIRS:
            raise _err(errno.ENOENT, path)
        if first == MAV_LOG:
            p = os.fsencode(LOGS_DIR) + b"/" + rest
        return self.jail.resolve(p, follow)

    def _writable(self, path: bytes, follow: bool = True) -> bytes:
        """As _local, and EROFS for a path in a virtual directory."""
        if path.lstrip(b"/").partition(b"/")[0] in VIRTUAL_DIRS:
            raise _err(errno.EROFS, path)
        return self._local(path, follow)

    def _virtual(self, path: bytes) -> BytesFile | None:
        p = path.lstrip(b"/")
        first, _, rest = p.partition(b"/")
        if first == SYS:
            return BytesFile(self.sys.content(rest), self.sys.size(rest))
        base, _, query = p.partition(b"?")
        make = self.virtual.get(base)
        if make is None:
            return None
        return BytesFile(make(b"withdefaults=1" in query))

    # ----- reading ----------------------------------------------------------------------------
    def open_read(self, path: bytes) -> BytesFile | DiskFile:
        v = self._virtual(path)
        return v if v is not None else DiskFile(self._local(path))

    def crc32(self, path: bytes) -> int:
        f = self.open_read(path)
        try:
            offset, chunks = 0, []
            while True:
                chunk = f.read(offset, 65536)
                if not chunk:
                    return ap_crc32(chunks)
                chunks.append(chunk)
                offset += len(chunk)
        finally:
            f.close()

    def listing(self, path: bytes) -> list[bytes]:
        first, _, rest = path.lstrip(b"/").partition(b"/")
        if first == SYS:
            if rest.strip(b"/"):
                raise _err(errno.ENOENT, path)      # @SYS has no subdirectories
            return self.sys.listing()
        real = self._local(path)
        out = [b"D.", b"D.."]
        with os.scandir(real) as it:
            entries = sorted(it, key=lambda e: e.name)
        for e in entries:
            name = os.fsencode(e.name)
            try:
                if e.is_symlink():
                    if not self.jail.entry_target_inside(real, name):
                        continue
                    out.append(b"F%s\t%d" % (name, os.stat(e.path).st_size & 0xFFFFFFFF))
                elif e.is_dir(follow_symlinks=False):
                    out.append(b"D" + name)
                elif e.is_file(follow_symlinks=False):
                    out.append(b"F%s\t%d" % (name, e.stat(follow_symlinks=False).st_size & 0xFFFFFFFF))
            except OSError:
                continue                    # gone or unreadable: ArduPilot drops it too
        if self.jail.is_root(real):
            out.append(b"D" + SYS)
            if os.path.isdir(os.path.join(real, os.fsencode(LOGS_DIR))):
                out.append(b"D" + MAV_LOG)
        return out

    # ----- writing ----------------------------------------------------------------------------
    def open_write(self, path: bytes, truncate: bool) -> StagedFile:
        """CreateFile (truncate) / OpenFileWO: a staged upload, in place when closed."""
        return StagedFile(self._writable(path), self.staging, truncate)

    def mkdir(self, path: bytes) -> None:
        os.mkdir(self._writable(path, follow=False), 0o775)

    def remove(self, path: bytes) -> None:
        """RemoveFile and RemoveDirectory alike, as AP_Filesystem_Posix::unlink: rmdir, then
        unlink; the error is unlink's. The root itself is not removable (EACCES)."""
        real = self._entry(path)
        try:
            os.rmdir(real)
        except OSError:
            os.unlink(real)

    def rename(self, old: bytes, new: bytes) -> None:
        os.rename(self._entry(old), self._entry(new))

    def truncate(self, path: bytes, length: int) -> None:
        os.truncate(self._writable(path), length)

    def _entry(self, path: bytes) -> bytes:
        real = self._writable(path, follow=False)
        if self.jail.is_root(real):
            raise _err(errno.EACCES, path)
        return real
