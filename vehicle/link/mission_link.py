"""Missions, the link capability: the pure mission protocol (vehicle/link/mission_protocol.py)
between the link core and the autopilot: messages in, replies out, plus the autopilot side
(MISSION_SET_CURRENT, MAV_CMD_DO_SET_MISSION_CURRENT, MISSION_ITEM_REACHED, the GUIDED "fly
to here" item with current = 2).

Replies go back on the channel the request came from; STATUSTEXT goes to every endpoint
(ArduPilot's gcs().send_text). MISSION_CURRENT (also streamed in SR0_EXT_STAT) is built by
the telemetry.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import MISSION
from vehicle.link.command_link import Command, CommandLink
from vehicle.link.link_core import LinkCore
from vehicle.link.mission_items import check_mission_item, from_int, from_legacy
from vehicle.link.mission_protocol import MissionProtocol, home_item
from vehicle.link.telemetry import Telemetry

# a guided item's frame as SET_POSITION_TARGET_GLOBAL_INT names it
GUIDED_FRAMES = {mav.MAV_FRAME_GLOBAL: mav.MAV_FRAME_GLOBAL_INT, mav.MAV_FRAME_MISSION: mav.MAV_FRAME_GLOBAL_INT,
                 mav.MAV_FRAME_GLOBAL_RELATIVE_ALT: mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
POSITION_ONLY = 0b110111111000      # POSITION_TARGET_TYPEMASK: x y z used; velocity, acceleration, yaw ignored

MISSION_MESSAGES = frozenset({"MISSION_COUNT", "MISSION_ITEM", "MISSION_ITEM_INT", "MISSION_REQUEST",
                              "MISSION_REQUEST_INT", "MISSION_REQUEST_LIST", "MISSION_WRITE_PARTIAL_LIST",
                              "MISSION_CLEAR_ALL", "MISSION_ACK"})


class MissionLink:
    def __init__(self, core: LinkCore, ap, telemetry: Telemetry, commands: CommandLink) -> None:
        """ap: the vehicle's autopilot (its mission store, runner and GUIDED target)."""
        self.core = core
        self.ap = ap
        self.telemetry = telemetry
        self.protocol = MissionProtocol(
            store=ap.missions, home_item=lambda: home_item(*ap.home_lla()),
            running=lambda: ap.mission_current()[1] == mav.MISSION_STATE_ACTIVE,
            current_seq=self._current_seq, stored=lambda t: ap.mission_uploaded(t))
        ap.outbox.subscribe(item_reached=self.item_reached)
        for msg_type in sorted(MISSION_MESSAGES | {"MISSION_SET_CURRENT"}):
            core.register(msg_type, self.handle)
        commands.register(mav.MAV_CMD_DO_SET_MISSION_CURRENT, self.command_set_current)
        core.on_tick(self.update)

    def _current_seq(self) -> int:
        seq, state = self.ap.mission_current()
        return seq if state in (mav.MISSION_STATE_ACTIVE, mav.MISSION_STATE_PAUSED) else -1

    def _send(self, outs) -> None:
        # replies first, then STATUSTEXT: ArduPilot queues its texts, so a GCS sees the
        # MISSION_ACK / next request before "Flight plan received" or a warning
        for o in outs:
            if o.msg is not None:
                self.core.send(o.msg, o.to)
        for o in outs:
            if o.msg is None:
                self.core.statustext(o.severity, o.text)

    def handle(self, m, channel) -> None:
        """A MISSION_* message for us."""
        if m.get_type() == "MISSION_SET_CURRENT":
            self.set_current(m.seq)
            return
        if m.get_type() in ("MISSION_ITEM", "MISSION_ITEM_INT") and m.current == 2 \
                and int(getattr(m, "mission_type", 0) or 0) == MISSION:
            self._guided_item(m, channel)
            return
        self._send(self.protocol.handle(m, (m.get_srcSystem(), m.get_srcComponent()), channel,
                                        self.core.clock()))

    def update(self) -> None:
        """Every tick: re-request what an upload is missing, or give up on a stalled one."""
        if self.protocol.uploads:
            self._send(self.protocol.update(self.core.clock()))

    def _guided_item(self, m, channel) -> None:
        """A mission item with current = 2 is a GUIDED "fly to here" (ArduPilot's
        handle_guided_request; MAVProxy's `guided` and Mission Planner's Fly To Here send it):
        checked like a mission item, then the autopilot's GUIDED position target; MISSION_ACK
        ACCEPTED, or ERROR when not in GUIDED."""
        src = (m.get_srcSystem(), m.get_srcComponent())
        if m.get_type() == "MISSION_ITEM":
            result, item = from_legacy(m, MISSION)
        else:
            item = from_int(m, MISSION)
            result = mav.MAV_MISSION_ACCEPTED
        if item is not None:
            result = check_mission_item(item)
        if result == mav.MAV_MISSION_ACCEPTED:
            frame = GUIDED_FRAMES.get(item.frame, item.frame)
            ok = self.ap.position_target_global(frame, POSITION_ONLY, item.x, item.y, item.z,
                                                (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, 0.0)
            result = mav.MAV_MISSION_ACCEPTED if ok else mav.MAV_MISSION_ERROR
        self.core.send(mav.MAVLink_mission_ack_message(src[0], src[1], result, MISSION), channel)

    # ----- the autopilot side -------------------------------------------------------------
    def set_current(self, seq) -> bool:
        """MISSION_SET_CURRENT: ArduPilot answers with MISSION_CURRENT when the seq is valid
        (and says nothing otherwise)."""
        ok = self.ap.set_mission_current(int(seq))
        if ok:
            self.core.send(self.telemetry.mission_current())
        return ok

    def command_set_current(self, c: Command) -> int:
        """MAV_CMD_DO_SET_MISSION_CURRENT (224): param1 seq, param2 1 = reset the mission first
        (handled by the runner through set_mission_current's seq)."""
        seq = c.params[0]
        if not math.isfinite(seq) or seq < 0 or seq > 65535:
            return mav.MAV_RESULT_DENIED
        return mav.MAV_RESULT_ACCEPTED if self.set_current(int(seq)) else mav.MAV_RESULT_FAILED

    def item_reached(self, seq: int) -> None:
        self.core.send(mav.MAVLink_mission_item_reached_message(int(seq)))
