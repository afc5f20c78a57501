"""A small MAVLink client for scripts: connect, wait, set mode, arm, take off, go, land.

Built on pymavlink, for ArduPilot-style vehicles (the towerlink SITL, or a real
ArduPilot behind the towerlink bridge). One `Client` holds one link; it tracks
every system it hears (heartbeat, mode, armed, position, landed state, STATUSTEXT)
and its blocking calls all take a deadline and raise a typed error when it passes.
Telemetry times are the vehicle's own (time_boot_ms, sim time); the wall clock is only
used for deadlines and resend intervals (with lockstep, the world's TICKs are used instead).

    from gcs.client import Client
    with Client.connect("udpout:127.0.0.1:14600") as c:
        c.wait_heartbeat(sysid=1, timeout=30)
        c.set_mode("GUIDED", sysid=1)
        c.arm(sysid=1)                      # reports PreArm: texts while it retries
        c.takeoff(9.0, sysid=1)             # NAV_TAKEOFF, waits for the height
        c.goto(10.0, 5.0, -9.0, sysid=1)    # SET_POSITION_TARGET_LOCAL_NED
        c.wait_reached((10.0, 5.0, -9.0), radius=0.5, timeout=60,
                       resend=lambda: c.goto(10.0, 5.0, -9.0, sysid=1))
        c.land(sysid=1)

The client is a link core (gcs.client.link: connection, heartbeats, signing, lockstep,
tlog, waiting) with a plugin per capability, as MAVSDK has them: ``c.action`` (mode, arm,
disarm, takeoff, land, rtl), ``c.telemetry`` (heartbeats, positions, times, STATUSTEXTs,
stream rates), ``c.goals`` (position goals and waiting to reach them), ``c.param``
(parameters) and ``c.commands`` (COMMAND_LONG until acknowledged). Their calls are also
the client's own: ``c.takeoff(...)`` is ``c.action.takeoff(...)``.

Every command is re-sent until acknowledged (the link may lose packets), and
state changes (mode, armed) are confirmed from the vehicle's heartbeat, so a
lost COMMAND_ACK does not fail a command that took effect.

Signing (MAVLink 2): ``Client.connect(..., signing_key=key)`` signs every packet the
client sends (heartbeats, commands, goals, lockstep JOIN/ACK/LEAVE) and accepts
only packets signed with the same key, fresh and in order (common.mavlink.signing.SignatureCheck:
signature first, then the timestamp); every other packet is dropped and counted by
reason in ``signing_refused`` (unsigned, bad_signature, replay, stale). A bridge started
with --signing-key, and vehicles given the key (``towerlink sitl --signing-key``), talk
only to such a client. Key text (passphrase or 64 hex digits) is read by
common.mavlink.signing.key_from_text, as MAVProxy's ``signing setup``.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from gcs.client.action import TAKEOFF_EVIDENCE_S, Action, mode_number
from gcs.client.commands import Commands
from gcs.client.errors import (RESULT_NAMES, ArmError, ClientError, ClientTimeout, CommandRejected,
                               CommandTimeout, GoalTimeout, HeartbeatTimeout, ModeChangeError,
                               TakeoffError, command_name, fmt_point)
from gcs.client.goals import MASK_POS_ONLY, MASK_POS_YAW, Goals, Reached
from gcs.client.link import SIGNING_LINK_ID, Link
from gcs.client.lockstep import LOCKSTEP_TIMEOUT
from gcs.client.param import Param
from gcs.client.state import REBOOT_JUMP_MS, Position, SystemState
from gcs.client.telemetry import Telemetry

__all__ = [
    "Client", "Link", "Action", "Commands", "Goals", "Param", "Telemetry",
    "Position", "SystemState", "Reached", "mode_number", "command_name", "fmt_point",
    "ClientError", "ClientTimeout", "HeartbeatTimeout", "CommandTimeout", "CommandRejected",
    "ModeChangeError", "ArmError", "TakeoffError", "GoalTimeout",
    "RESULT_NAMES", "SIGNING_LINK_ID", "LOCKSTEP_TIMEOUT", "REBOOT_JUMP_MS", "TAKEOFF_EVIDENCE_S",
    "MASK_POS_ONLY", "MASK_POS_YAW",
]


def _forward(plugin: str, method: Callable[..., Any]) -> Callable[..., Any]:
    """A Client method that is `method` of the client's plugin attribute `plugin`."""
    def call(self: Client, *args: Any, **kwargs: Any) -> Any:
        return method(getattr(self, plugin), *args, **kwargs)
    functools.update_wrapper(call, method)
    call.__qualname__ = f"Client.{method.__name__}"
    return call


class Client(Link):
    """One MAVLink link (gcs.client.link.Link) with its capability plugins (see the module docstring)."""

    def __init__(self, master: Any, **kw: Any) -> None:
        """`master`: a pymavlink connection (Client.connect opens one); `kw`: see Link."""
        super().__init__(master, **kw)
        self.commands = Commands(self)
        self.telemetry = Telemetry(self, self.commands)
        self.action = Action(self, self.commands, self.telemetry)
        self.goals = Goals(self)
        self.param = Param(self)

    # the plugins' calls on the client itself: c.takeoff(...) is c.action.takeoff(...)
    command_long = _forward("commands", Commands.command_long)
    set_mode = _forward("action", Action.set_mode)
    arm = _forward("action", Action.arm)
    disarm = _forward("action", Action.disarm)
    takeoff = _forward("action", Action.takeoff)
    land = _forward("action", Action.land)
    rtl = _forward("action", Action.rtl)
    sim_time = _forward("telemetry", Telemetry.sim_time)
    position = _forward("telemetry", Telemetry.position)
    statustexts_since = _forward("telemetry", Telemetry.statustexts_since)
    wait_heartbeat = _forward("telemetry", Telemetry.wait_heartbeat)
    wait_position = _forward("telemetry", Telemetry.wait_position)
    set_message_interval = _forward("telemetry", Telemetry.set_message_interval)
    goto = _forward("goals", Goals.goto)
    goto_named = _forward("goals", Goals.goto_named)
    wait_reached = _forward("goals", Goals.wait_reached)
    get_param = _forward("param", Param.get_param)
