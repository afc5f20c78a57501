"""A vehicle's log folder as ArduPilot's File backend keeps it (AP_Logger_File.cpp):
numbered logs `00000001.BIN` ... and `LASTLOG.TXT` holding the newest number.

A new log takes the number after LASTLOG's (re-using it when that file is empty), wrapping
to 1 above `max_files`; LASTLOG.TXT is replaced atomically (written beside, then renamed),
so a crash leaves the old or the new number, never half of one. The logs' bytes are
appended by the writer thread (vehicle/logs/writer.py); this class only names, lists,
reads and erases files.

The MAVLink log list numbers logs 1..N from the oldest on disk to the newest
(`AP_Logger_File::log_num_from_list_entry`): `entries()` gives them in that order.
"""
from __future__ import annotations

import os
import re
from collections.abc import Callable, Collection
from dataclasses import dataclass
from pathlib import Path

LASTLOG = "LASTLOG.TXT"
MAX_FILES = 500                 # LOG_MAX_FILES: ArduPilot's upper bound
_NAME = re.compile(r"^(\d{8})\.BIN$")


@dataclass(frozen=True)
class LogInfo:
    """One log on disk: its number, size in bytes and modification time (unix s)."""
    num: int
    size: int
    mtime: int


def log_name(num: int) -> str:
    """ArduPilot's file name of log `num`: 8 digits and .BIN."""
    return f"{num:08d}.BIN"


class LogStore:
    """The numbered logs in one folder (created on first use)."""

    def __init__(self, folder: str | os.PathLike | Callable[[], Path], max_files: int = MAX_FILES) -> None:
        """folder: the directory, or a function giving it when first needed (a vehicle's
        temporary root is made only if it logs)."""
        self._folder = folder if callable(folder) else Path(folder)
        self.max_files = max(2, int(max_files))

    @property
    def folder(self) -> Path:
        f = self._folder
        if callable(f):
            f = self._folder = Path(f())
        return f

    def path(self, num: int) -> Path:
        return self.folder / log_name(num)

    def numbers(self) -> list[int]:
        """Log numbers present on disk, ascending."""
        try:
            names = os.listdir(self.folder)
        except FileNotFoundError:
            return []
        return sorted(int(m.group(1)) for m in map(_NAME.match, names) if m)

    def last_number(self) -> int:
        """LASTLOG.TXT's number (0 when there is none or it cannot be read)."""
        try:
            text = (self.folder / LASTLOG).read_text("ascii", "replace")
        except OSError:
            return 0
        digits = re.match(r"\s*(\d+)", text)
        return int(digits.group(1)) if digits else 0

    def entries(self) -> list[LogInfo]:
        """The logs oldest first (list entry 1 = the oldest): after a wrap, the numbers
        above LASTLOG's are the older ones."""
        nums = self.numbers()
        last = self.last_number()
        ordered = [n for n in nums if n > last] + [n for n in nums if n <= last]
        out = []
        for n in ordered:
            try:
                st = os.stat(self.path(n))
            except FileNotFoundError:
                continue
            out.append(LogInfo(n, st.st_size, int(st.st_mtime)))
        return out

    def new_log(self, busy: Collection[int] = ()) -> Path:
        """Name the next log, create it empty and record its number in LASTLOG.TXT;
        returns its path. An empty newest log is re-used unless its number is `busy` (its
        bytes are still on their way to the disk)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        last = self.last_number() or max(self.numbers(), default=0)
        num = last
        if last == 0 or last in busy or not self._empty(last):
            num = last + 1 if last < self.max_files else 1
        path = self.path(num)
        with open(path, "wb"):
            pass
        self._write_lastlog(num)
        return path

    def _empty(self, num: int) -> bool:
        try:
            return os.path.getsize(self.path(num)) == 0
        except OSError:
            return True

    def _write_lastlog(self, num: int) -> None:
        tmp = self.folder / f"{LASTLOG}.tmp{os.getpid()}"
        with open(tmp, "w", encoding="ascii", newline="") as f:
            f.write(f"{num}\r\n")
        os.replace(tmp, self.folder / LASTLOG)

    def read(self, num: int, ofs: int, count: int) -> bytes:
        """Up to `count` bytes of log `num` from `ofs` (fewer at its end, b'' past it)."""
        try:
            with open(self.path(num), "rb") as f:
                f.seek(ofs)
                return f.read(count)
        except OSError:
            return b""

    def erase(self) -> None:
        """Remove every numbered log and LASTLOG.TXT (ArduPilot's EraseAll)."""
        for n in self.numbers():
            try:
                os.unlink(self.path(n))
            except FileNotFoundError:
                pass
        try:
            os.unlink(self.folder / LASTLOG)
        except FileNotFoundError:
            pass
