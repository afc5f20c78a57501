"""The copter's side of AUTO, RTL's destination (rally) and the fence action (a mixin of
CopterAutopilot; setpoints in world NED).

AUTO sub-modes (auto.AutoMode.sub): takeoff (straight up), wp (position target, yaw by
WP_YAW_BEHAVIOR / ROI / CONDITION_YAW), land (LAND's descent), rtl (RTL's climb, return,
land, without RTL's own disarm: the mission decides), circle (NAV_LOITER_TURNS: to the
edge, then round at CIRCLE_RATE deg/s capped by WPNAV_SPEED, facing the centre), loiter.
On the ground AUTO idles until "auto armed" and a takeoff; DISARM_DELAY still applies.
WP_YAW_BEHAVIOR: 0 keep heading, 1 face next waypoint, 2 face next waypoint except RTL
(default), 3 face along the track (here: as 1).
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import wrap_pi
from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mission_store import RALLY
from vehicle.autopilot.rally import best_return, rally_points

FACE_MIN_M = 2.0              # closer than this to the destination: keep the heading
DEFAULT_CIRCLE_RADIUS_M = 10.0


class CopterAutoFlight:
    """Methods CopterAutopilot gains for AUTO, rally RTL and fence actions."""

    # ----- RTL destination (rally) --------------------------------------------------------
    def rtl_destination(self) -> np.ndarray:
        home = self.home if self.home is not None else self.start_ned
        pts = rally_points(self.missions.items(RALLY), self.origin, float(home[2]))
        fence = self.fence if self.fence.active() else None
        dest, _ = best_return(self.pos, home, pts, float(self.params.get("RALLY_LIMIT_KM", 0.3)),
                              int(self.params.get("RALLY_INCL_HOME", 1)) == 1,
                              (lambda p: fence.destination_ok(p)) if fence else None)
        return dest

    def rtl_start(self) -> None:
        """RTL's entry: climb to RTL_ALT (or stay higher), then return to home / rally point."""
        self.refresh()
        self.hold_here()
        self.rtl_stage = "climb"
        self.rtl_dest = self.rtl_destination()
        rtl_alt = float(self.params.get("RTL_ALT", 1500)) / 100.0
        home_z = self.home[2] if self.home is not None else 0.0
        self.rtl_z = min(self.pos[2], home_z - rtl_alt)

    def rtl_complete(self) -> bool:
        return self.rtl_stage == "land" and self.on_ground

    # ----- AUTO -----------------------------------------------------------------------------
    def auto_fly(self, a, dt: float) -> None:
        if not self.armed:
            self.setpoint()
            return
        sub = a.sub
        if self.on_ground and not (sub == "takeoff" and a.auto_armed):
            self.ground_idle()
            return
        self.landed_since = None
        if sub == "takeoff":
            self.setpoint(pos=a.dest, yaw=self.hold_yaw)
            self.echo = GuidedTarget("pos", a.dest.copy(), None, None, self.hold_yaw, None)
        elif sub == "wp" and not a.paused:
            yaw = self._auto_yaw(a, dt)
            self.setpoint(pos=a.dest, yaw=yaw)
            self.echo = GuidedTarget("pos", a.dest.copy(), None, None, yaw, None)
        elif sub == "land":
            self._land(dt)
        elif sub == "rtl":
            self._rtl(dt)
        elif sub == "circle":
            self._circle(a, dt)
        else:
            self.setpoint(pos=self.hold_pos, yaw=self._auto_yaw(a, dt, face=False))

    def _auto_yaw(self, a, dt: float, face: bool = True) -> float:
        if a.roi is not None:
            d = a.roi[:2] - self.pos[:2]
            if np.linalg.norm(d) > 0.5:
                self.hold_yaw = math.atan2(d[1], d[0])
        elif a.fixed_yaw is not None:
            # CONDITION_YAW turns at its own rate (param2 deg/s); the attitude loop may be slower
            step = a.yaw_rate_max * dt
            err = wrap_pi(a.fixed_yaw - self.hold_yaw)
            self.hold_yaw = wrap_pi(self.hold_yaw + max(-step, min(step, err)))
        elif face and int(self.params.get("WP_YAW_BEHAVIOR", 2)) != 0 and a.dest is not None:
            d = a.dest[:2] - self.pos[:2]
            if np.linalg.norm(d) > FACE_MIN_M:
                self.hold_yaw = math.atan2(d[1], d[0])
        return self.hold_yaw

    def _circle(self, a, dt: float) -> None:
        c = a.circle
        center = c["center"]
        r = c["radius"] if c["radius"] > 0 else DEFAULT_CIRCLE_RADIUS_M
        rel = self.pos[:2] - center[:2]
        if c["angle"] is None:
            dist = float(np.linalg.norm(rel))
            u = rel / dist if dist > 0.1 else np.array([1.0, 0.0])
            edge = np.array([center[0] + r * u[0], center[1] + r * u[1], center[2]])
            if abs(dist - r) > 3.0 or abs(self.pos[2] - center[2]) > 1.0:
                self.setpoint(pos=edge, yaw=self.hold_yaw)
                return
            c["angle"] = math.atan2(u[1], u[0])
        vmax = float(self.params.get("WPNAV_SPEED", 500)) / 100.0
        omega = min(math.radians(abs(float(self.params.get("CIRCLE_RATE", 20)))), vmax / r)
        sign = -1.0 if c["ccw"] else 1.0
        c["angle"] += sign * omega * dt
        c["total"] += omega * dt
        ang = c["angle"]
        pos = np.array([center[0] + r * math.cos(ang), center[1] + r * math.sin(ang), center[2]])
        vel = np.array([-sign * omega * r * math.sin(ang), sign * omega * r * math.cos(ang), 0.0])
        self.hold_yaw = wrap_pi(ang + math.pi)          # face the centre
        self.setpoint(pos=pos, vel=vel, yaw=self.hold_yaw)
        self.echo = GuidedTarget("posvel", pos, vel, None, self.hold_yaw, None)

    def ground_idle(self) -> None:
        """On the ground without a takeoff: idle, auto-disarm after DISARM_DELAY."""
        if self.landed_since is None:
            self.landed_since = self.t
        delay = float(self.params.get("DISARM_DELAY", 10))
        if delay > 0 and self.t - self.landed_since >= delay:
            self.disarm(force=True, reason="auto-disarm")
            return
        self.setpoint()
        self.hold_here()

    # ----- fence ----------------------------------------------------------------------------
    def fence_action_copter(self, action: int, far_outside: bool) -> None:
        if self.on_ground:
            self.disarm(force=True, reason="fence breach")
            return
        if far_outside or action in (2, 4, 5):
            self.set_mode(modes.LAND, "fence breach")
            return
        if not self.set_mode(modes.RTL, "fence breach"):
            self.set_mode(modes.LAND, "fence breach")
