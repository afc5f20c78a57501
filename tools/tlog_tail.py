"""Read a tlog while it is still being written: the messages of the frames that came since the last read.

The same frames, decoded the same way, as tools.run_data.read_tlog gives for the finished file
(its cutter and decoder): a tlog's writer may leave a part of a frame at the end, which is kept
for the next read. Bytes that are not a tlog make :meth:`TlogTail.read` raise NotATlog (the
reader of the finished file then falls back to pymavlink's robust reader, which this does not).
"""
from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from tools.run_data import decode_frames, tlog_prefix_frames, wanted_ids


class NotATlog(ValueError):
    """The file holds bytes that are not stamps and whole MAVLink frames."""


class TlogTail:
    """The messages of `path` (those of `types` by name, from `sysids`; None: all), read as
    they come. The file need not exist yet. With `scene` (a tools.tlog_stamped.StampedDecoder)
    they are decoded as far as its reader reads them (`types` is then not used)."""

    def __init__(self, path: str | Path, types: Iterable[str] | None = None,
                 sysids: Iterable[int] | None = None, scene=None) -> None:
        from common.mavlink.dialect import towerlink as dialect
        self.path = Path(path)
        self._scene = scene
        self._mav = dialect.MAVLink(None)
        self._wanted = wanted_ids(dialect, types)
        self._sysids = None if sysids is None else frozenset(sysids)
        self._file = None
        self._rest = b""        # the start of a frame still being written

    def read(self) -> list[Any]:
        """The messages of the whole frames written since the last read."""
        if self._file is None:
            try:
                self._file = open(self.path, "rb")
            except FileNotFoundError:
                return []
        raw = self._rest + self._file.read()
        cut = tlog_prefix_frames(raw)
        if cut is None:
            raise NotATlog(f"{self.path} is not a tlog")
        frames, end = cut
        self._rest = raw[end:]
        if self._scene is not None:
            return list(self._scene.decode(raw, frames, self._sysids))
        return list(decode_frames(self._mav, raw, frames, self._wanted, self._sysids))

    @property
    def complete(self) -> bool:
        """No part of a frame is left over (the finished file was whole)."""
        return not self._rest

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
