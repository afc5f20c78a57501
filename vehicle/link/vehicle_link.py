"""One vehicle's MAVLink side: the link core (vehicle/link/link_core.py) with the capabilities
of an ArduPilot vehicle plugged in, as MAVSDK's plugins sit on its core.

  telemetry   vehicle/link/telemetry.py       the messages, built from the autopilot
  streams     vehicle/link/stream_link.py     when they go out; REQUEST_DATA_STREAM, message intervals
  commands    vehicle/link/command_link.py    COMMAND_LONG / COMMAND_INT, SET_MODE, reboot
  params      vehicle/link/param_link.py      PARAM_*
  missions    vehicle/link/mission_link.py    MISSION_* (missions, fences, rally points)
  files       vehicle/link/ftp_link.py        MAVFTP (the vehicle's root directory, @PARAM/param.pck)
  positions   vehicle/link/position_link.py   position targets, the EKF origin, FOLLOW's lead
  logs        vehicle/link/log_link.py        the onboard DataFlash log and LOG_* (its download)
  sticks      vehicle/link/rc_link.py         RC_CHANNELS_OVERRIDE, MANUAL_CONTROL (pilot input)

Each registers with the core the message types and commands it answers; STATUSTEXT and
MISSION_ITEM_REACHED come from the autopilot's outbox, to which the link subscribes.
"""
from __future__ import annotations

import os
from collections.abc import Callable, Mapping

from vehicle.link.command_link import CommandLink
from vehicle.link.ftp_link import FtpLink
from vehicle.link.link_core import Intake, LinkCore
from vehicle.link.log_link import LogLink
from vehicle.link.mission_link import MissionLink
from vehicle.link.outbox import DIRECT, Outbox
from vehicle.link.param_link import ParamLink
from vehicle.link.position_link import PositionLink
from vehicle.link.rc_link import RcLink
from vehicle.link.stream_link import StreamLink
from vehicle.link.telemetry import Telemetry
from vehicle.logs.world_logs import WorldLogs
from vehicle.telemetry import version
from vehicle.vehicle_root import logs_dir


class VehicleLink(LinkCore):
    def __init__(self, ap, clock: Callable[[], float], unix_start_us: int, endpoints: list[str],
                 signing_key: bytes | None = None,
                 params_changed: Callable[[Mapping[str, float]], None] | None = None,
                 intake: Intake | None = None, files_root: str | os.PathLike | None = None,
                 logs: WorldLogs | None = None, outbox: Outbox = DIRECT) -> None:
        """ap: the autopilot; clock() the world's sim time (s); unix_start_us: the unix time of
        sim t = 0; endpoints: pymavlink connection strings; params_changed({name: value})
        after an accepted PARAM_SET; intake: what sees the UDP datagrams first (lockstep);
        files_root: the directory MAVFTP serves (vehicle/vehicle_root.py), None for a
        temporary one removed at close(); logs: the world's onboard logs (this vehicle's in
        its files root's logs/), None for none (LOG_* requests unanswered); outbox: what holds the
        endpoints' writes while the world steps (vehicle/link/outbox.py)."""
        super().__init__(ap.sysid, clock, endpoints, signing_key, intake, outbox)
        self.ap = ap
        self.telemetry = Telemetry(ap, self.framer, clock, unix_start_us)
        self.commands = CommandLink(self, ap)
        self.streams = StreamLink(self, ap.params, self.telemetry, self.commands,
                                  banner=lambda: version.banner(ap.kind, ap.sysid))
        self.params = ParamLink(self, ap.params, self.streams, params_changed)
        self.missions = MissionLink(self, ap, self.telemetry, self.commands)
        # before files: at close the log is closed before a temporary root is removed
        self.logs = (LogLink(self, ap, logs, lambda: logs_dir(self.files.root.path()), unix_start_us)
                     if logs is not None else None)
        self.files = FtpLink(self, ap.params, files_root)
        self.positions = PositionLink(self, ap, self.telemetry)
        self.sticks = RcLink(self, ap)
        ap.outbox.subscribe(text=self.statustext)
