"""Onboard logs, the link capability: the vehicle's DataFlash log (vehicle/logs/) kept every
autopilot tick, and the MAVLink log download served from it: LOG_REQUEST_LIST,
LOG_REQUEST_DATA, LOG_REQUEST_END and LOG_ERASE answered as ArduPilot answers them
(vehicle/logs/transfer.py), replies on the requesting channel only.

STATUSTEXTs reach the log through the autopilot's outbox (MSG records). A reboot closes the
open log (the next boot opens the next one) and ends any transfer; closing the link closes
the log. A transfer whose channel went away (a TCP client disconnected) ends.
"""
from __future__ import annotations

from vehicle.link.link_core import LinkCore
from vehicle.logs.transfer import LogTransfer
from vehicle.logs.vehicle_log import VehicleLog

LOG_MESSAGES = ("LOG_REQUEST_LIST", "LOG_REQUEST_DATA", "LOG_REQUEST_END", "LOG_ERASE")


class LogLink:
    def __init__(self, core: LinkCore, ap, log: VehicleLog) -> None:
        """ap: the autopilot (armed state, what the log records); log: its onboard log."""
        self.core = core
        self.ap = ap
        self.log = log
        self.transfer = LogTransfer(log)
        for name in LOG_MESSAGES:
            core.register(name, self.on_log_message)
        core.on_tick(self.tick)
        core.on_reboot(self.rebooted)
        core.on_close(self.closed)
        ap.outbox.subscribe(text=log.text, mode=log.mode_changed, arming=log.arming_changed)

    def on_log_message(self, m, ch) -> None:
        for msg, to in self.transfer.handle(m, ch, bool(self.ap.armed)):
            self.core.send(msg, to)

    def tick(self) -> None:
        self.log.update(self.ap, self.core.clock())
        t = self.transfer
        if t.channel is None:
            return
        if t.channel.closed:
            t.end()
            return
        for msg, to in t.pump(bool(self.ap.armed)):
            self.core.send(msg, to)

    def rebooted(self) -> None:
        """A new boot: the old log is closed, no transfer under way."""
        self.log.stop(self.ap.params.values)
        self.transfer = LogTransfer(self.log)

    def closed(self) -> None:
        self.log.stop(self.ap.params.values)
