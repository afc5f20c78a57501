"""Telemetry streams, the link capability: which message goes out how often, and the
requests that change it (the link core sends what is due, framed by the telemetry).

The schedule: HEARTBEAT at 1 Hz, each SR0_* stream group at its parameter's rate
(vehicle/telemetry/stream_groups.py, per vehicle kind), and MAV_CMD_SET_MESSAGE_INTERVAL's per-message
intervals over both (-1 disables a message, 0 restores its default). REQUEST_DATA_STREAM sets
the SR0_* parameters (not saved), as ArduPilot does. MAV_CMD_GET_MESSAGE_INTERVAL,
MAV_CMD_REQUEST_MESSAGE and MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES answer after their ACK.

Streams are framed without message objects (vehicle/link/framing.py) and only while an
endpoint has someone to hear them. A reboot forgets the message intervals.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.link.command_link import Command, CommandLink
from vehicle.link.link_core import LinkCore, statustext_message
from vehicle.link.telemetry import DATA_STREAMS, Telemetry

MAX_INTERVAL_US = 2**31 - 1   # MESSAGE_INTERVAL.interval_us is an int32


class StreamLink:
    def __init__(self, core: LinkCore, params, telemetry: Telemetry, commands: CommandLink,
                 banner: Callable[[], list[str]]) -> None:
        """params: the vehicle's ParamStore (SR0_* rates); telemetry builds the messages;
        banner() the lines MAV_CMD_DO_SEND_BANNER answers with."""
        self.core = core
        self.banner = banner
        self.params = params
        self.telemetry = telemetry
        self.intervals: dict[int, float] = {}     # msgid -> seconds; <0 disabled (SET_MESSAGE_INTERVAL)
        core.stream_from(telemetry)
        self.rebuild()
        core.register("REQUEST_DATA_STREAM", self.on_request_data_stream)
        for cmd in (mav.MAV_CMD_SET_MESSAGE_INTERVAL, mav.MAV_CMD_GET_MESSAGE_INTERVAL,
                    mav.MAV_CMD_REQUEST_MESSAGE, mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES):
            commands.register(cmd, self.command)
        commands.register(mav.MAV_CMD_DO_SEND_BANNER, self.send_banner)
        core.on_reboot(self.forget)

    def rebuild(self) -> None:
        """The schedule from the SR0_* parameters and the message intervals (after either changed)."""
        sched: dict[int, float] = {mav.MAVLINK_MSG_ID_HEARTBEAT: 1.0}
        for group, ids in self.telemetry.groups.items():
            hz = float(self.params.get(group, 0) or 0)
            if hz > 0:
                for i in ids:
                    sched[i] = min(sched.get(i, math.inf), 1.0 / hz)
        for i, iv in self.intervals.items():
            if iv < 0:
                sched.pop(i, None)
            else:
                sched[i] = iv
        self.core.set_schedule(sched)

    def forget(self) -> None:
        """A reboot: the message intervals are gone."""
        self.intervals.clear()
        self.rebuild()

    def on_request_data_stream(self, m, ch) -> None:
        rate = m.req_message_rate if m.start_stop else 0
        groups = list(DATA_STREAMS.values()) if m.req_stream_id == mav.MAV_DATA_STREAM_ALL \
            else [DATA_STREAMS.get(m.req_stream_id)]
        for g in groups:
            if g is not None:
                self.params.set(g, min(max(rate, 0), 50), save=False)
        self.rebuild()

    def send_banner(self, c: Command) -> int:
        """MAV_CMD_DO_SEND_BANNER: ArduPilot's banner STATUSTEXTs, on the asking link only."""
        c.after_ack.extend(statustext_message(mav.MAV_SEVERITY_INFO, line) for line in self.banner())
        return mav.MAV_RESULT_ACCEPTED

    def command(self, c: Command) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL, GET_MESSAGE_INTERVAL, REQUEST_MESSAGE and
        REQUEST_AUTOPILOT_CAPABILITIES, as ArduPilot answers them."""
        cmd, p = c.command, c.params
        if not all(math.isfinite(v) for v in p[:2]):
            return mav.MAV_RESULT_DENIED
        builders = self.telemetry.builders
        if cmd == mav.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            if p[0] != 1:                  # ArduPilot: param1 1 asks for the version
                return mav.MAV_RESULT_FAILED
            c.after_ack.append(self.telemetry.autopilot_version())
            return mav.MAV_RESULT_ACCEPTED
        if not 0 <= p[0] <= 2**24 - 1:          # MAVLink 2 message ids are 24 bits
            return mav.MAV_RESULT_DENIED
        msgid = int(p[0])
        if cmd == mav.MAV_CMD_REQUEST_MESSAGE:
            # ArduPilot: an id it has no ap_message for -> FAILED; a known one -> ACCEPTED, and
            # the message follows when there is one to send (HOME_POSITION / GPS_GLOBAL_ORIGIN
            # before home / the origin are set: ACCEPTED, nothing sent)
            if msgid not in builders:
                return mav.MAV_RESULT_FAILED
            c.after_ack.extend(self.telemetry.build_all(msgid))
            return mav.MAV_RESULT_ACCEPTED
        if cmd == mav.MAV_CMD_GET_MESSAGE_INTERVAL:
            if msgid not in builders:
                return mav.MAV_RESULT_DENIED
            iv = self.core.schedule.get(msgid)
            # ArduPilot keeps whole milliseconds and answers interval_ms * 1000
            c.after_ack.append(mav.MAVLink_message_interval_message(msgid, -1 if iv is None else round(iv * 1e3) * 1000))
            return mav.MAV_RESULT_ACCEPTED
        return self._set_interval(msgid, p[1])

    def _set_interval(self, msgid: int, us: float) -> int:
        """SET_MESSAGE_INTERVAL: `us` the interval in microseconds; -1 disable; 0 default."""
        if msgid not in self.telemetry.builders or msgid == mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            self.core.statustext(mav.MAV_SEVERITY_INFO, f"No ap_message for mavlink id ({msgid})"[:50])
            return mav.MAV_RESULT_DENIED
        if us > MAX_INTERVAL_US:
            return mav.MAV_RESULT_DENIED
        if us == 0:
            self.intervals.pop(msgid, None)
        elif us < 0:
            self.intervals[msgid] = -1.0
        else:
            self.intervals[msgid] = max(int(us) // 1000, 1) * 1e-3     # whole ms, at least 1, as ArduPilot
        self.rebuild()
        return mav.MAV_RESULT_ACCEPTED
