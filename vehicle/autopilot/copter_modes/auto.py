"""AUTO (ArduCopter/mode_auto.cpp ModeAuto): flies the stored mission.

The mission half (which command runs, when each is done) is vehicle/autopilot/auto.py's
AutoMission; this flies its sub-modes (AutoMission.sub): takeoff (straight up), wp (position
target, yaw by WP_YAW_BEHAVIOR / ROI / CONDITION_YAW), land (LAND's descent), rtl (the RTL
mode object's climb, return and landing, without RTL's own disarm: the mission decides),
circle (NAV_LOITER_TURNS: to the edge, then round at CIRCLE_RATE deg/s capped by WPNAV_SPEED,
facing the centre), loiter. On the ground it idles until "auto armed" and a takeoff;
DISARM_DELAY still applies. The mission runs disarmed too, as ArduCopter's. Arming in AUTO
needs AUTO_OPTIONS bit 0 (AllowArming); with bit 1 (AllowTakeOffWithoutRaisingThrottle) the
takeoff sub-mode auto-arms an armed copter every tick, as ModeAuto::takeoff_run does, so a
copter armed in GUIDED and switched to AUTO takes off too. WP_YAW_BEHAVIOR: 0 keep heading, 1 face next waypoint, 2 face next
waypoint except RTL (default), 3 face along the track (here: as 1). Setpoints: world NED.
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import wrap_pi
from vehicle.autopilot import modes
from vehicle.autopilot.auto import MissionMode
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mode import ArmingMethod

FACE_MIN_M = 2.0              # closer than this to the destination: keep the heading
DEFAULT_CIRCLE_RADIUS_M = 10.0
EDGE_M, EDGE_ALT_M = 3.0, 1.0  # off the circle's edge by more than these: fly to the edge first
ALLOW_ARMING, ALLOW_TAKEOFF_WITHOUT_THROTTLE = 1, 2      # AUTO_OPTIONS bits


class ModeAuto(MissionMode, CopterMode):
    number = modes.AUTO
    position_required, autopilot_mode = True, True
    reports_guided_enabled = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self._fly_sub = {"takeoff": self._takeoff, "wp": self._wp, "land": self._land,
                         "rtl": self._rtl, "circle": self._circle}

    def allows_arming(self, method: ArmingMethod) -> bool:
        return bool(int(self.ap.params.get("AUTO_OPTIONS", 0)) & ALLOW_ARMING)

    def allows_arming_with_throttle_high(self) -> bool:
        return self.allows_arming(ArmingMethod.MAVLINK)

    def disarms_on_failsafe(self, throttle_zero: bool) -> bool:
        """Landed with the mission not started (not auto-armed)."""
        return not self.ap.auto_armed and self.ap.on_ground and not self.ap.takeoff.running

    def takeoff_without_throttle(self) -> bool:
        """AUTO_OPTIONS bit 1: the takeoff auto-arms (no throttle to raise)."""
        return bool(int(self.ap.params.get("AUTO_OPTIONS", 0)) & ALLOW_TAKEOFF_WITHOUT_THROTTLE)

    def mission_stepped(self) -> None:
        """ModeAuto::takeoff_run: AUTO_OPTIONS bit 1 auto-arms (no throttle to raise)."""
        ap = self.ap
        if self.mission.sub == "takeoff" and ap.armed and self.takeoff_without_throttle():
            ap.auto_armed = True

    def is_taking_off(self) -> bool:
        return self.mission.sub == "takeoff" and self.ap.auto_armed

    def is_landing(self) -> bool:
        sub = self.mission.sub
        return sub == "land" or (sub == "rtl" and self.mission.rtl.is_landing())

    # ----- the sub-modes --------------------------------------------------------------------
    def fly(self, dt: float) -> None:
        self._fly_sub.get(self.mission.sub, self._loiter)(dt)

    def _takeoff(self, dt: float) -> None:
        ap, dest = self.ap, self.mission.dest
        ap.setpoint(pos=dest, yaw=ap.hold_yaw)
        ap.echo = GuidedTarget("pos", dest.copy(), None, None, ap.hold_yaw, None)

    def _wp(self, dt: float) -> None:
        m = self.mission
        if m.paused:
            self._loiter(dt)
            return
        yaw = self._yaw(dt)
        self.ap.setpoint(pos=m.dest, yaw=yaw)
        self.ap.echo = GuidedTarget("pos", m.dest.copy(), None, None, yaw, None)

    def _land(self, dt: float) -> None:
        self.land_run(dt)

    def _rtl(self, dt: float) -> None:
        self.mission.rtl.fly(dt)

    def _loiter(self, dt: float) -> None:
        self.ap.setpoint(pos=self.ap.hold_pos, yaw=self._yaw(dt, face=False))

    def _yaw(self, dt: float, face: bool = True) -> float:
        ap, m = self.ap, self.mission
        if m.roi is not None:
            d = m.roi[:2] - ap.pos[:2]
            if np.linalg.norm(d) > 0.5:
                ap.hold_yaw = math.atan2(d[1], d[0])
        elif m.fixed_yaw is not None:
            # CONDITION_YAW turns at its own rate (param2 deg/s); the attitude loop may be slower
            step = m.yaw_rate_max * dt
            err = wrap_pi(m.fixed_yaw - ap.hold_yaw)
            ap.hold_yaw = wrap_pi(ap.hold_yaw + max(-step, min(step, err)))
        elif face and int(ap.params.get("WP_YAW_BEHAVIOR", 2)) != 0 and m.dest is not None:
            d = m.dest[:2] - ap.pos[:2]
            if np.linalg.norm(d) > FACE_MIN_M:
                ap.hold_yaw = math.atan2(d[1], d[0])
        return ap.hold_yaw

    def _circle(self, dt: float) -> None:
        ap = self.ap
        c = self.mission.circle
        center = c["center"]
        r = c["radius"] if c["radius"] > 0 else DEFAULT_CIRCLE_RADIUS_M
        rel = ap.pos[:2] - center[:2]
        if c["angle"] is None:
            dist = float(np.linalg.norm(rel))
            u = rel / dist if dist > 0.1 else np.array([1.0, 0.0])
            edge = np.array([center[0] + r * u[0], center[1] + r * u[1], center[2]])
            if abs(dist - r) > EDGE_M or abs(ap.pos[2] - center[2]) > EDGE_ALT_M:
                ap.setpoint(pos=edge, yaw=ap.hold_yaw)
                return
            c["angle"] = math.atan2(u[1], u[0])
        vmax = float(ap.params.get("WPNAV_SPEED", 500)) / 100.0
        omega = min(math.radians(abs(float(ap.params.get("CIRCLE_RATE", 20)))), vmax / r)
        sign = -1.0 if c["ccw"] else 1.0
        c["angle"] += sign * omega * dt
        c["total"] += omega * dt
        ang = c["angle"]
        pos = np.array([center[0] + r * math.cos(ang), center[1] + r * math.sin(ang), center[2]])
        vel = np.array([-sign * omega * r * math.sin(ang), sign * omega * r * math.cos(ang), 0.0])
        ap.hold_yaw = wrap_pi(ang + math.pi)          # face the centre
        ap.setpoint(pos=pos, vel=vel, yaw=ap.hold_yaw)
        ap.echo = GuidedTarget("posvel", pos, vel, None, ap.hold_yaw, None)
