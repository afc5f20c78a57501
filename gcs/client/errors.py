"""The errors gcs.client raises, and the names they print (MAV_CMD, MAV_RESULT)."""
from __future__ import annotations

from collections.abc import Iterable, Sequence

from gcs.client.mav import mavlink

# MAV_RESULT names, for messages.
RESULT_NAMES = {
    0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED",
    4: "FAILED", 5: "IN_PROGRESS", 6: "CANCELLED",
}


def command_name(cmd: int) -> str:
    """'MAV_CMD_NAV_TAKEOFF' for 22; the number as text when the dialect does not know it."""
    try:
        return mavlink.enums["MAV_CMD"][cmd].name
    except (KeyError, AttributeError):
        return str(cmd)


def fmt_point(p: Iterable[float]) -> str:
    """'[1.00, 2.00, -3.00]': a point for a message, cm resolution."""
    return "[" + ", ".join(f"{v:.2f}" for v in p) + "]"


class ClientError(Exception):
    """Base of every error gcs.client raises."""


class ClientTimeout(ClientError, TimeoutError):
    """A deadline passed before the vehicle did what was asked."""


class HeartbeatTimeout(ClientTimeout):
    """No heartbeat from the system within the deadline."""


class CommandTimeout(ClientTimeout):
    """No COMMAND_ACK for a command, however often it was re-sent."""


class CommandRejected(ClientError):
    """The vehicle answered a command with a result other than ACCEPTED."""

    def __init__(self, command: int, result: int, detail: str = "") -> None:
        self.command = command
        self.result = result
        name = RESULT_NAMES.get(result, str(result))
        super().__init__(f"command {command_name(command)} rejected: {name}"
                         + (f" ({detail})" if detail else ""))


class ModeChangeError(ClientTimeout):
    """The vehicle did not report the requested mode before the deadline."""


class ArmError(ClientError):
    """Arming failed; `prearm` holds the PreArm/Arm STATUSTEXTs the vehicle sent."""

    def __init__(self, message: str, prearm: Sequence[str] = (), result: int | None = None) -> None:
        self.prearm = list(prearm)
        self.result = result
        if self.prearm:
            message += ": " + "; ".join(self.prearm)
        super().__init__(message)


class TakeoffError(ClientError):
    """Takeoff was refused or the height was not reached in time."""


class GoalTimeout(ClientTimeout):
    """The vehicle did not come within the radius of a goal before the deadline."""

    def __init__(self, goal: Sequence[float], radius: float, distance: float | None,
                 timeout: float) -> None:
        self.goal = tuple(goal)
        self.radius = radius
        self.distance = distance
        d = "no position received" if distance is None else f"last distance {distance:.2f} m"
        super().__init__(f"goal {fmt_point(goal)} not reached within {radius:g} m "
                         f"in {timeout:g} s ({d})")
