"""COMMAND_LONG / COMMAND_INT for one autopilot, as ArduPilot's GCS_MAVLINK handles them:
MAV_CMD -> a handler -> MAV_RESULT. The commands both vehicles take are here; each vehicle
adds its own (copter_commands.py, rover_commands.py).

Parameters arrive as floats (NaN and infinities included: a bad one is DENIED where ArduPilot
checks it). COMMAND_INT gives x, y = latitude, longitude * 1e7 and its frame.

MAV_CMD_DO_GRIPPER is answered as ArduPilot answers it with no gripper enabled (GRIP_ENABLE 0,
its default: GCS_MAVLINK's gripper handler says FAILED and nothing else); towerlink
simulates no gripper.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.reposition import RepositionDenied
from vehicle.autopilot.reposition import decode as decode_reposition

ACCEPTED = mav.MAV_RESULT_ACCEPTED
DENIED = mav.MAV_RESULT_DENIED
FAILED = mav.MAV_RESULT_FAILED
UNSUPPORTED = mav.MAV_RESULT_UNSUPPORTED
TEMPORARILY_REJECTED = mav.MAV_RESULT_TEMPORARILY_REJECTED

FORCE_MAGIC = (21196, 2989)   # ArduPilot's param2 to force arm / disarm
MAX_HOME_M = 50_000.0         # m from the EKF origin: ArduPilot refuses a home further away


def wire_int(v: float, lo: int, hi: int) -> int | None:
    """A command parameter (float on the wire) as an integer in lo..hi, or None when it is
    NaN, infinite, fractional or out of range (the caller answers DENIED)."""
    if not math.isfinite(v) or v != round(v) or not lo <= v <= hi:
        return None
    return int(v)


def finite(p, *idx: int) -> bool:
    """True when the command parameters at `idx` (0-based) are all finite numbers."""
    return all(math.isfinite(p[i]) for i in idx)


def result(ok: bool) -> int:
    return ACCEPTED if ok else FAILED


class Commands:
    """The commands of autopilot `ap`; subclasses add theirs to `handlers`."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self.handlers = {
            mav.MAV_CMD_COMPONENT_ARM_DISARM: self.arm_disarm,
            mav.MAV_CMD_DO_SET_MODE: self.set_mode,
            mav.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda p, frame, x, y: result(ap.set_mode(ap.RTL)),
            mav.MAV_CMD_DO_SET_HOME: self.set_home,
            mav.MAV_CMD_DO_CHANGE_SPEED: lambda p, frame, x, y: ap.speed.change(p[1]),
            mav.MAV_CMD_MISSION_START: self.mission_start,
            mav.MAV_CMD_DO_PAUSE_CONTINUE: self.pause_continue,
            mav.MAV_CMD_DO_SET_MISSION_CURRENT: lambda p, frame, x, y: result(ap.set_mission_current(p[0])),
            mav.MAV_CMD_DO_FENCE_ENABLE: self.fence_enable,
            mav.MAV_CMD_DO_REPOSITION: self.reposition,
            mav.MAV_CMD_DO_FLIGHTTERMINATION: self.flight_termination,
            mav.MAV_CMD_PREFLIGHT_CALIBRATION: self.calibration,
            mav.MAV_CMD_DO_GRIPPER: lambda p, frame, x, y: FAILED,     # no gripper enabled
        }

    def handle(self, cmd: int, p: list[float], frame: int | None = None,
               x: int | None = None, y: int | None = None) -> int:
        """The command's MAV_RESULT (UNSUPPORTED for a command this vehicle does not take)."""
        self.ap.refresh()
        handler = self.handlers.get(cmd)
        return UNSUPPORTED if handler is None else handler(p, frame, x, y)

    # ----- the shared commands -----------------------------------------------------------
    def arm_disarm(self, p, frame, x, y) -> int:
        force = any(abs(p[1] - magic) < 0.5 for magic in FORCE_MAGIC)
        if p[0] == 1:
            return self.ap.arm(force)
        if p[0] == 0:
            return self.ap.disarm(force)
        return DENIED

    def set_mode(self, p, frame, x, y) -> int:
        base, custom = wire_int(p[0], 0, 255), wire_int(p[1], 0, 2**32 - 1)
        if base is None or custom is None:
            return DENIED             # NaN, inf or a non-integer where a mode number goes
        if base & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return result(self.ap.set_mode(custom))
        return DENIED

    def set_home(self, p, frame, x, y) -> int:
        """DO_SET_HOME: param1 1 = here, 0 = the position given (relative frames above home)."""
        ap = self.ap
        if p[0] not in (0, 1):
            return DENIED             # param1 is a flag: current position (1) or the one given (0)
        if p[0] == 1:
            if not ap.est_ok:
                return FAILED
            ap.home = ap.pos.copy()
            ap.text(mav.MAV_SEVERITY_INFO, "Home set")
            return ACCEPTED
        lat = x * 1e-7 if x is not None else p[4]
        lon = y * 1e-7 if y is not None else p[5]
        alt = p[6]
        if not all(math.isfinite(v) for v in (lat, lon, alt)) or (lat == 0 and lon == 0) \
                or abs(lat) > 90 or abs(lon) > 180:
            return FAILED
        if frame in (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
            alt += ap.home_lla()[2]
        ned = np.asarray(geo.lla_to_ned(ap.origin, lat, lon, alt))
        if np.linalg.norm(ned) > MAX_HOME_M:
            return FAILED
        ap.home = ned
        ap.text(mav.MAV_SEVERITY_INFO, "Home set")
        return ACCEPTED

    def mission_start(self, p, frame, x, y) -> int:
        """MISSION_START: ArduPilot refuses first/last items (DENIED), else AUTO and go."""
        ap = self.ap
        if p[0] != 0 or p[1] != 0:
            return DENIED
        if not ap.set_mode(ap.AUTO):
            return FAILED
        ap.auto.mission.mission_start()
        return ACCEPTED

    def pause_continue(self, p, frame, x, y) -> int:
        """DO_PAUSE_CONTINUE: param1 0 pause, 1 continue the current mode (Mode.pause/resume);
        other param1 DENIED; a mode that cannot: FAILED, "Failed to pause" / "Failed to resume"."""
        if p[0] not in (0, 1):
            return DENIED
        mode = self.ap.flightmode
        ok = mode.pause() if p[0] == 0 else mode.resume()
        if not ok:
            self.ap.text(mav.MAV_SEVERITY_INFO, "Failed to pause" if p[0] == 0 else "Failed to resume")
        return result(ok)

    def fence_enable(self, p, frame, x, y) -> int:
        if p[0] not in (0, 1):
            return FAILED
        self.ap.fence.set_enabled(p[0] == 1)
        return ACCEPTED

    def reposition(self, p, frame, x, y) -> int:
        """DO_REPOSITION (reposition.py): GUIDED if asked and needed, then the target, as
        ArduCopter (a target GUIDED refuses -> FAILED)."""
        ap = self.ap
        in_guided = ap.flightmode.in_guided_mode()
        try:
            rp = decode_reposition(p, frame, x, y, ap.home_lla()[2], in_guided)
        except RepositionDenied:
            return DENIED
        ned = np.asarray(geo.lla_to_ned(ap.origin, rp.lat, rp.lon, rp.alt_amsl), float)
        if not in_guided and not ap.set_mode(ap.GUIDED, "GCS"):
            return FAILED
        self.reposition_speed(rp.speed)
        return result(ap.guided.targets.accept(GuidedTarget("pos", ned, None, None, None, None)))

    def reposition_speed(self, speed: float | None) -> None:
        """DO_REPOSITION's param1 (m/s or None): ArduCopter ignores it (Rover overrides)."""

    def flight_termination(self, p, frame, x, y) -> int:
        """ArduPilot without AFS: param1 > 0.5 disarms at once (a copter falls), else FAILED."""
        if not finite(p, 0):
            return DENIED
        if p[0] > 0.5:
            self.ap.disarm(force=True, reason="flight termination")
            return ACCEPTED
        return FAILED

    def calibration(self, p, frame, x, y) -> int:
        """PREFLIGHT_CALIBRATION: ArduPilot's "*preflight*, remember?" -> TEMPORARILY_REJECTED
        while armed; the simulated sensors need no calibration, so it succeeds at once."""
        if not finite(p, 0, 1, 2, 3, 4, 5, 6):
            return DENIED
        if self.ap.armed:
            return TEMPORARILY_REJECTED
        self.ap.text(mav.MAV_SEVERITY_INFO, "Calibration successful")
        return ACCEPTED
