"""What an autopilot says to the outside: STATUSTEXTs and MISSION_ITEM_REACHED.

The autopilot is a pure core: it does not know its links. It is given an Outbox when it is
built and says things into it; whoever carries them out (the vehicle's MAVLink link, a
test, a benchmark) subscribes. The outbox outlives a reboot, so subscribers stay.
"""
from __future__ import annotations

from collections.abc import Callable

TextListener = Callable[[int, str], None]       # (MAV_SEVERITY, text)
ReachedListener = Callable[[int], None]         # mission seq


class Outbox:
    """Fan-out of an autopilot's messages to its subscribers, in subscription order."""

    def __init__(self) -> None:
        self._text: list[TextListener] = []
        self._reached: list[ReachedListener] = []

    def subscribe(self, text: TextListener | None = None,
                  item_reached: ReachedListener | None = None) -> None:
        """Add listeners: `text(severity, message)`, `item_reached(seq)`."""
        if text is not None:
            self._text.append(text)
        if item_reached is not None:
            self._reached.append(item_reached)

    def text(self, severity: int, message: str) -> None:
        """A STATUSTEXT (MAV_SEVERITY, at most 50 characters on the wire)."""
        for f in self._text:
            f(severity, message)

    def item_reached(self, seq: int) -> None:
        """MISSION_ITEM_REACHED for mission item `seq`."""
        for f in self._reached:
            f(seq)
