"""What an autopilot says to the outside: STATUSTEXTs and MISSION_ITEM_REACHED, and what
its onboard log records as it happens: mode changes and arming.

The autopilot is a pure core: it does not know its links. It is given an Outbox when it is
built and says things into it; whoever carries them out (the vehicle's MAVLink link, a
test, a benchmark) subscribes. The outbox outlives a reboot, so subscribers stay.
"""
from __future__ import annotations

from collections.abc import Callable

TextListener = Callable[[int, str], None]       # (MAV_SEVERITY, text)
ReachedListener = Callable[[int], None]         # mission seq
ModeListener = Callable[[int, str], None]       # (mode number, reason: "GCS", "battery failsafe"...)
ArmingListener = Callable[[bool, bool, str], None]   # (armed, forced, why it disarmed or "")


class Outbox:
    """Fan-out of an autopilot's messages to its subscribers, in subscription order."""

    def __init__(self) -> None:
        self._text: list[TextListener] = []
        self._reached: list[ReachedListener] = []
        self._mode: list[ModeListener] = []
        self._arming: list[ArmingListener] = []

    def subscribe(self, text: TextListener | None = None,
                  item_reached: ReachedListener | None = None,
                  mode: ModeListener | None = None, arming: ArmingListener | None = None) -> None:
        """Add listeners: `text(severity, message)`, `item_reached(seq)`,
        `mode(number, reason)`, `arming(armed, forced, reason)`."""
        for kind, f in ((self._text, text), (self._reached, item_reached), (self._mode, mode),
                        (self._arming, arming)):
            if f is not None:
                kind.append(f)

    def text(self, severity: int, message: str) -> None:
        """A STATUSTEXT (MAV_SEVERITY, at most 50 characters on the wire)."""
        for f in self._text:
            f(severity, message)

    def item_reached(self, seq: int) -> None:
        """MISSION_ITEM_REACHED for mission item `seq`."""
        for f in self._reached:
            f(seq)

    def mode(self, number: int, reason: str) -> None:
        """The vehicle entered mode `number` (why, as set_mode was told)."""
        for f in self._mode:
            f(number, reason)

    def arming(self, armed: bool, forced: bool, reason: str) -> None:
        """The vehicle armed or disarmed (forced or not; why it disarmed, "" when asked to)."""
        for f in self._arming:
            f(armed, forced, reason)
