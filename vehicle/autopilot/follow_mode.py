"""ArduPilot's FOLLOW mode (Copter 23, Rover 6): follow another MAVLink vehicle by its
GLOBAL_POSITION_INT, with an offset in NED or relative to the lead's heading.

What ArduPilot does (libraries/AP_Follow, ArduCopter/mode_follow.cpp, Rover/mode_follow.cpp),
and so what this does:

* FOLL_ENABLE must be 1 or the mode is refused ("Set FOLL_ENABLE = 1" on Copter).
* The lead is FOLL_SYSID; 0 = the first system heard sending GLOBAL_POSITION_INT (not
  ourselves), forgotten after 10 s of silence. A fix older than 3 s is no target.
* The lead's position is projected forward by its velocity since the fix arrived. Altitude:
  relative_alt above *our* home (FOLL_ALT_TYPE 1, the Copter default) or AMSL (0); Rover
  ignores z.
* Offset FOLL_OFS_X/Y/Z (m): FOLL_OFS_TYPE 0 north/east/down; 1 forward/right/down of the
  lead's heading (GLOBAL_POSITION_INT.hdg), rotated by that heading.
* A target further than FOLL_DIST_MAX (m) from us is no target (ArduPilot marks it invalid).
* Desired velocity = lead velocity + FOLL_POS_P * (offset target - our position), limited to
  the horizontal speed limit (WPNAV_SPEED, Copter; CRUISE_SPEED-like WP_SPEED, Rover) and,
  on Copter, the climb/descent limits; it slows down near the target (the sqrt controller
  ArduPilot's AC_Avoid::limit_velocity uses, with half the horizontal acceleration).
* Copter yaw, FOLL_YAW_BEHAVE: 0 none, 1 face the lead (if > 1 m away), 2 the lead's
  heading, 3 direction of flight (above 1 m/s).
* No valid target: Copter holds (zero velocity), Rover stops.

Frames: everything here is the SITL world's NED (m, z down); the lead's latitude and
longitude are converted with common.geo from the world origin, as every other global target.
Pure: the autopilot passes sim time in; no sockets, no clocks.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common import geo

TIMEOUT = 3.0               # s: AP_FOLLOW_TIMEOUT_MS
SYSID_TIMEOUT = 10.0        # s: AP_FOLLOW_SYSID_TIMEOUT_MS


@dataclass
class LeadFix:
    """One GLOBAL_POSITION_INT of the lead, in world NED (m, m/s), heading rad, sim time s."""
    t: float
    pos: np.ndarray
    vel: np.ndarray
    heading: float | None


@dataclass
class FollowCommand:
    """What the mode asks of the vehicle: a world-NED velocity (m/s), an optional yaw (rad)."""
    vel: np.ndarray
    yaw: float | None
    target: np.ndarray          # offset target position (m, world NED), for reporting
    dist: float                 # m from us to the offset target


class Follow:
    """AP_Follow's target estimate plus the mode's velocity law, for one vehicle."""

    def __init__(self, params, own_sysid, world_origin: tuple[float, float, float]) -> None:
        self.params = params                   # a ParamStore-like mapping with .get()
        self.own_sysid = own_sysid             # () -> our MAVLink sysid
        self.world_origin = world_origin
        self.sysid: int | None = None          # the lead we follow (FOLL_SYSID, or learnt)
        self.last_heard = -1e9
        self.fix: LeadFix | None = None

    # ----- input: the lead's GLOBAL_POSITION_INT --------------------------------------
    def enabled(self) -> bool:
        return int(self.params.get("FOLL_ENABLE", 0)) == 1

    def on_global_position(self, sysid: int, msg, t: float, home_alt: float) -> bool:
        """Take a GLOBAL_POSITION_INT (MAVLink units) heard at sim time t; True if used.

        home_alt: our home's altitude (m AMSL); relative_alt is taken above it."""
        if not self.enabled() or sysid == self.own_sysid():
            return False
        want = int(self.params.get("FOLL_SYSID", 0))
        if want:
            self.sysid = want
        elif self.sysid is None or t - self.last_heard > SYSID_TIMEOUT:
            self.sysid = sysid                  # the first one heard
        if sysid != self.sysid:
            return False
        try:
            lat, lon = msg.lat * 1e-7, msg.lon * 1e-7
            rel = msg.relative_alt * 1e-3
            vel = np.array([msg.vx, msg.vy, msg.vz], float) * 0.01
            hdg = None if msg.hdg == 65535 else math.radians(msg.hdg * 0.01)
        except (AttributeError, TypeError, ValueError):
            return False
        if (abs(lat) > 90 or abs(lon) > 180 or (lat == 0 and lon == 0)
                or not all(math.isfinite(v) for v in (lat, lon, rel, *vel))):
            return False
        alt = home_alt + rel if int(self.params.get("FOLL_ALT_TYPE", 1)) == 1 else msg.alt * 1e-3
        n, e, down = geo.lla_to_ned(self.world_origin, lat, lon, alt)
        self.fix = LeadFix(t, np.array([n, e, down]), vel, hdg)
        self.last_heard = t
        return True

    # ----- the target ---------------------------------------------------------------
    def target(self, t: float, pos: np.ndarray):
        """(lead position, offset target position, lead velocity, lead heading) at sim time t, or None
        when there is no valid target (none, stale, too far)."""
        f = self.fix
        if f is None or t - f.t > TIMEOUT:
            return None
        lead = f.pos + f.vel * max(0.0, t - f.t)           # projected by its velocity
        ofs = np.array([float(self.params.get("FOLL_OFS_X", 0.0)), float(self.params.get("FOLL_OFS_Y", 0.0)),
                        float(self.params.get("FOLL_OFS_Z", 0.0))])
        if int(self.params.get("FOLL_OFS_TYPE", 0)) == 1 and f.heading is not None:
            c, s = math.cos(f.heading), math.sin(f.heading)
            ofs = np.array([c * ofs[0] - s * ofs[1], s * ofs[0] + c * ofs[1], ofs[2]])
        dist_max = float(self.params.get("FOLL_DIST_MAX", 100.0))
        if dist_max > 0 and float(np.linalg.norm(lead - pos)) > dist_max:
            return None
        return lead, lead + ofs, f.vel, f.heading

    def command(self, t: float, pos: np.ndarray, speed_max: float, accel_max: float,
                z_limits: tuple[float, float] | None) -> FollowCommand | None:
        """The velocity to fly (m/s, world NED) now; None: no valid target (hold / stop).

        speed_max: horizontal speed limit (m/s); accel_max: horizontal acceleration (m/s^2)
        for the slow-down near the target; z_limits: (max climb, max descent) m/s, or None
        for a ground vehicle (z ignored)."""
        got = self.target(t, pos)
        if got is None:
            return None
        lead, goal, lead_vel, heading = got
        kp = float(self.params.get("FOLL_POS_P", 0.1))
        err = goal - pos
        vel = lead_vel + kp * err
        sxy = math.hypot(vel[0], vel[1])
        if sxy > speed_max > 0:
            vel[:2] *= speed_max / sxy
        # slow down as the target nears: at most the speed that stops in the distance left
        # with half the acceleration (AC_Avoid::limit_velocity's sqrt controller idea)
        dxy = math.hypot(err[0], err[1])
        if dxy > 1e-6:
            toward = (vel[0] * err[0] + vel[1] * err[1]) / dxy
            cap = math.sqrt(2.0 * 0.5 * accel_max * dxy) + math.hypot(lead_vel[0], lead_vel[1])
            if toward > cap:
                vel[:2] -= (toward - cap) * err[:2] / dxy
        if z_limits is None:
            vel[2] = 0.0
        else:
            up, dn = z_limits
            vel[2] = min(max(vel[2], -up), dn)
        return FollowCommand(vel, self._yaw(lead - pos, heading, vel), goal, float(np.linalg.norm(err)))

    def _yaw(self, to_lead: np.ndarray, heading: float | None, vel: np.ndarray) -> float | None:
        behave = int(self.params.get("FOLL_YAW_BEHAVE", 1))
        if behave == 1 and math.hypot(to_lead[0], to_lead[1]) > 1.0:
            return math.atan2(to_lead[1], to_lead[0])
        if behave == 2 and heading is not None:
            return heading
        if behave == 3 and math.hypot(vel[0], vel[1]) > 1.0:
            return math.atan2(vel[1], vel[0])
        return None
