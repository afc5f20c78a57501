"""The world's outgoing datagrams, held while it steps and written when it yields.

Every write to a UDP peer or a TCP client wakes a reader (the bridge, fly's monitor, a GCS).
On a machine with fewer free cores than busy processes the woken reader takes the world's
core: a world that wrote its telemetry at every autopilot tick lost its CPU in the middle of
its stepping, several times a lockstep frame (at --speedup max its sendto calls took most of
its wall time). So the world corks its endpoints while it steps a chunk and flushes them, in
the order written, before it waits (for a TICK's ACKs, for the pacing, for I/O): the readers
then run while the world would be waiting anyway. Datagrams are kept as written (none merged);
a reader gets them at most one chunk later (a lockstep frame, or 20 ms of stepping), and a
lockstep participant acts on them at the TICK that follows them either way.

Uncorked (outside the stepping, e.g. replies sent while the world waits), writes go at once.
"""
from __future__ import annotations

from collections.abc import Callable


class Outbox:
    def __init__(self) -> None:
        self._held: list[tuple[Callable, tuple]] | None = None     # None: not corked

    def cork(self) -> None:
        """Hold writes from now until flush()."""
        if self._held is None:
            self._held = []

    def send(self, write: Callable, *args) -> None:
        """write(*args) now, or at flush() when corked."""
        if self._held is None:
            write(*args)
        else:
            self._held.append((write, args))

    def push(self) -> None:
        """Write what is held, in order, and go on holding if corked (a pipelined lockstep
        TICK: the participants work on the frame while the world steps the next)."""
        if self._held:
            held, self._held = self._held, []
            self._write(held)

    def flush(self) -> None:
        """Write what was held, in order, and stop holding."""
        held, self._held = self._held, None
        self._write(held or ())

    @staticmethod
    def _write(held) -> None:
        for write, args in held:
            try:
                write(*args)
            except (OSError, RuntimeError):     # a peer gone meanwhile: as an immediate write would
                pass


#: the outbox of endpoints built without one: never corked
DIRECT = Outbox()
