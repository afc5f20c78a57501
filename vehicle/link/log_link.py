"""Onboard logs, the link capability: the vehicle's DataFlash log (vehicle/logs/) kept every
autopilot tick, and the MAVLink log download served from it: LOG_REQUEST_LIST,
LOG_REQUEST_DATA, LOG_REQUEST_END and LOG_ERASE answered as ArduPilot answers them
(vehicle/logs/transfer.py), replies on the requesting channel only.

What happens reaches the log through the autopilot's outbox: STATUSTEXT (MSG), mode changes
(MODE), arming (ARM, EV). A reboot closes the open log (the next boot opens the next one) and
ends any transfer; closing the link closes the log. A transfer whose channel went away (a TCP
client disconnected) ends.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from vehicle.link.link_core import LinkCore
from vehicle.logs.transfer import LogTransfer
from vehicle.logs.world_logs import WorldLogs
from vehicle.telemetry import version

LOG_MESSAGES = ("LOG_REQUEST_LIST", "LOG_REQUEST_DATA", "LOG_REQUEST_END", "LOG_ERASE")


class LogLink:
    def __init__(self, core: LinkCore, ap, logs: WorldLogs, folder: Callable[[], Path], unix_start_us: int) -> None:
        """ap: the autopilot; logs: the world's; folder(): where this vehicle's logs live;
        unix_start_us: the unix time of sim t = 0 (the GPS records' clock)."""
        self.core = core
        self.ap = ap
        self._writer = logs.writer
        # a log opens with ArduPilot's banner (firmware string, system id, frame) of this boot
        self.log = logs.for_vehicle(ap.kind, folder, core.clock, unix_start_us,
                                    lambda: version.banner(ap.kind, ap.sysid), phase=ap.sysid)
        self.transfer = LogTransfer(self.log)
        for name in LOG_MESSAGES:
            core.register(name, self.on_log_message)
        core.on_tick(self.tick)
        core.on_reboot(self.rebooted)
        core.on_close(self.closed)
        ap.outbox.subscribe(text=self.log.text, mode=self.log.mode_changed, arming=self.log.arming_changed)

    def on_log_message(self, m, ch) -> None:
        """One LOG_REQUEST_LIST / DATA / END or LOG_ERASE for this vehicle."""
        for msg, to in self.transfer.handle(m, ch, bool(self.ap.armed)):
            self.core.send(msg, to)

    def tick(self) -> None:
        """Every autopilot tick: the log, then whatever download is under way."""
        self.log.update(self.ap, self.core.clock())
        t = self.transfer
        if t.channel is None:
            return
        if t.channel.closed:
            t.end()
            return
        for msg, to in t.pump(bool(self.ap.armed)):
            self.core.send(msg, to)

    def set_unix_start(self, unix_start_us: int) -> None:
        """Sim t = 0 at this unix time (µs): the GPS records' clock."""
        self.log.set_unix_start(unix_start_us)

    def rebooted(self) -> None:
        """A new boot: the old log is closed, no transfer under way."""
        self.log.stop(self.ap.params.values)
        self.transfer = LogTransfer(self.log)

    def closed(self) -> None:
        """The link closes: the log is closed and its last bytes are on disk before the link's
        files close (a temporary root is removed then: the writer thread must be done with it)."""
        self.log.stop(self.ap.params.values)
        self._writer.flush()
