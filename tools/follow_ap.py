"""`towerlink fly --follow-with ardupilot|both`: a rover follows the drone with ArduPilot's own
FOLLOW mode instead of (or beside) the bridge's tf follow.

How the lead's position reaches the follower: inside one `towerlink sitl` world the vehicles
hear each other's GLOBAL_POSITION_INT at 10 Hz sim (vehicle.world.World.share_positions: a
shared telemetry network, as ArduPilot vehicles on one radio or behind one mavlink-router);
across processes a router would forward it (the vehicle takes GLOBAL_POSITION_INT on any link).
The bridge does not forward it: it does not route broadcast vehicle messages to other
vehicles, as mavlink-router and ArduPilot do not echo a link's broadcast back to vehicles.

This driver only sets the follower up, over the world's push link (the run's vehicles.tlog
socket): FOLL_ENABLE 1, FOLL_SYSID = the drone, FOLL_OFS_TYPE 1 (the lab's yaw-only frame is
the same idea) with the scenario's follow offset, then FOLLOW (Rover 6) and arm, all in one
go (the vehicle handles them in order, so FOLL_ENABLE is set when FOLLOW is asked for),
repeated every half wall second until the rover's HEARTBEAT says FOLLOW and armed. The
monitor is no lockstep participant: when FOLLOW starts (a few sim seconds in, before the
first goal) varies a little from run to run, and so does ArduPilot's follow figure. FOLL_POS_P stays at
ArduPilot's default (0.1) unless --foll-pos-p is given.
"""
from __future__ import annotations

import time

ROVER_FOLLOW = 6
RETRY = 0.5                      # wall s between attempts


class ApFollowDriver:
    def __init__(self, send, sysid: int, lead_sysid: int, offset=(0.0, 0.0), pos_p: float | None = None,
                 clock=time.monotonic) -> None:
        from common.mavlink.dialect import towerlink as tl
        self.tl = tl
        self._send = send                # (target sysid, message) -> bool: sent
        self.sysid = sysid
        self.params = {"FOLL_ENABLE": 1.0, "FOLL_SYSID": float(lead_sysid), "FOLL_OFS_TYPE": 1.0,
                       "FOLL_OFS_X": float(offset[0]), "FOLL_OFS_Y": float(offset[1])}
        if pos_p is not None:
            self.params["FOLL_POS_P"] = float(pos_p)
        self.clock = clock
        self.confirmed: dict[str, float] = {}
        self.mode: int | None = None
        self.armed = False
        self._last = -1e9

    def on_message(self, m) -> None:
        """Every message from the world's push link (the Monitor calls this)."""
        if m.get_srcSystem() != self.sysid:
            return
        t = m.get_type()
        if t == "HEARTBEAT" and m.get_srcComponent() == 1:
            self.mode = m.custom_mode
            self.armed = bool(m.base_mode & self.tl.MAV_MODE_FLAG_SAFETY_ARMED)
        elif t == "PARAM_VALUE":
            name = m.param_id if isinstance(m.param_id, str) else m.param_id.decode(errors="replace")
            name = name.rstrip("\x00")
            if name in self.params and abs(m.param_value - self.params[name]) < 1e-4:
                self.confirmed[name] = m.param_value

    @property
    def following(self) -> bool:
        return self.mode == ROVER_FOLLOW and self.armed

    def tick(self) -> None:
        """Called often; acts at most every RETRY wall s until the rover follows."""
        now = self.clock()
        if self.following or now - self._last < RETRY:
            return
        self._last = now
        tl = self.tl
        for name, value in self.params.items():
            if name not in self.confirmed:
                self._send(self.sysid, tl.MAVLink_param_set_message(self.sysid, 1, name.encode(), value,
                                                                    tl.MAV_PARAM_TYPE_REAL32))
        if self.mode != ROVER_FOLLOW:
            self._send(self.sysid, tl.MAVLink_command_long_message(
                self.sysid, 1, tl.MAV_CMD_DO_SET_MODE, 0, tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                ROVER_FOLLOW, 0, 0, 0, 0, 0))
        if not self.armed:
            self._send(self.sysid, tl.MAVLink_command_long_message(
                self.sysid, 1, tl.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0))
