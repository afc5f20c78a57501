"""Commands and actions, the link capability: COMMAND_LONG / COMMAND_INT, SET_MODE, the
ground station's HEARTBEAT and MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN.

Every COMMAND_LONG / COMMAND_INT for us gets exactly one COMMAND_ACK on the channel it came
from, also when a handler fails (FAILED, the traceback printed, counted as handler_error).
A command goes to the capability that registered it (`register`), else to the autopilot.
Like ArduPilot, the ACK goes first, then the messages the command asked for
(`Command.after_ack`) and then, for a reboot, the reboot.
"""
from __future__ import annotations

import math
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.link.endpoints import Channel
from vehicle.link.link_core import LinkCore


@dataclass
class Command:
    """One COMMAND_LONG / COMMAND_INT for us."""
    command: int                  # MAV_CMD
    params: list[float]           # param1..param7 (COMMAND_INT's x, y as floats)
    frame: int | None             # COMMAND_INT's MAV_FRAME, None for COMMAND_LONG
    x: int | None                 # COMMAND_INT's x, y (degE7 or local), None for COMMAND_LONG
    y: int | None
    msg: object                   # the message (who sent it)
    channel: Channel
    after_ack: list = field(default_factory=list)    # messages sent on the channel after the ACK


CommandHandler = Callable[[Command], int]           # -> MAV_RESULT


class CommandLink:
    def __init__(self, core: LinkCore, ap) -> None:
        """ap: the vehicle's autopilot (commands nobody registered, modes, arming, reboot)."""
        self.core = core
        self.ap = ap
        self.handlers: dict[int, CommandHandler] = {mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._reboot_command}
        self._reboot_after_ack = False
        core.register("COMMAND_LONG", self.on_command_long)
        core.register("COMMAND_INT", self.on_command_int)
        core.register("SET_MODE", self.on_set_mode)
        core.register("HEARTBEAT", self.on_heartbeat)

    def register(self, command: int, handler: CommandHandler) -> None:
        """`handler(Command) -> MAV_RESULT` answers every `command` (one capability per command)."""
        if command in self.handlers:
            raise ValueError(f"command {command} is already handled by {self.handlers[command]!r}")
        self.handlers[command] = handler

    def ack(self, ch: Channel, command: int, result: int, m) -> None:
        self.core.send(mav.MAVLink_command_ack_message(command, result, 0, 0, m.get_srcSystem(),
                                                       m.get_srcComponent()), ch)

    def on_heartbeat(self, m, ch) -> None:
        """A ground station is there (the autopilot's GCS failsafe counts its heartbeats)."""
        if m.type == mav.MAV_TYPE_GCS:
            self.ap.gcs_heartbeat()

    def on_command_long(self, m, ch) -> None:
        p = [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]
        self._run(Command(m.command, p, None, None, None, m, ch))

    def on_command_int(self, m, ch) -> None:
        p = [m.param1, m.param2, m.param3, m.param4, float(m.x), float(m.y), m.z]
        self._run(Command(m.command, p, m.frame, m.x, m.y, m, ch))

    def _run(self, c: Command) -> None:
        self._reboot_after_ack = False
        try:
            handler = self.handlers.get(c.command)
            result = handler(c) if handler is not None else \
                int(self.ap.command(c.command, c.params, c.frame, c.x, c.y))
        except Exception:       # a handler bug: still exactly one ACK, and say where
            self.core.stats["handler_error"] += 1
            traceback.print_exc()
            result, c.after_ack = mav.MAV_RESULT_FAILED, []
            self._reboot_after_ack = False
        self.ack(c.channel, c.command, result, c.msg)
        for msg in c.after_ack:
            self.core.send(msg, c.channel)
        if self._reboot_after_ack:
            self._reboot_after_ack = False
            self.reboot()

    def on_set_mode(self, m, ch) -> None:
        if m.base_mode & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            result = mav.MAV_RESULT_ACCEPTED if self.ap.set_mode(m.custom_mode) else mav.MAV_RESULT_FAILED
        else:
            result = mav.MAV_RESULT_DENIED
        self.ack(ch, mav.MAVLINK_MSG_ID_SET_MODE, result, m)

    # ----- reboot ----------------------------------------------------------------------------
    def _reboot_command(self, c: Command) -> int:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN as ArduPilot (GCS_Common.cpp): refused while armed
        (FAILED, checked first); param1 1 reboots, 3 (into the bootloader) reboots the same here
        (no bootloader to hold in); anything else UNSUPPORTED. The ACK goes out first, from the
        old sysid."""
        p = c.params
        if not all(math.isfinite(v) for v in p[:2]):
            return mav.MAV_RESULT_DENIED
        if self.ap.armed:
            return mav.MAV_RESULT_FAILED
        if p[0] not in (1, 3):
            return mav.MAV_RESULT_UNSUPPORTED
        self._reboot_after_ack = True
        return mav.MAV_RESULT_ACCEPTED

    def reboot(self) -> None:
        """Reboot the simulated vehicle: the autopilot re-reads its parameters and starts
        afresh (modes, home, targets, failsafes); the link takes the new SYSID_THISMAV and
        forgets message intervals and queued replies. Peers and the world clock stay (the
        world's clock is every vehicle's time_boot_ms, so it does not restart)."""
        self.ap.reboot()
        self.core.rebooted(self.ap.sysid)
