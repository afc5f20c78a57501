"""ArduCopter-like autopilot: STABILIZE, AUTO, GUIDED (takeoff, targets), LOITER, RTL, LAND.

Setpoints per mode (world NED, sent to the CopterFleet every autopilot tick):
  GUIDED   on the ground: nothing (motors idle) until NAV_TAKEOFF; in the air: the last
           target (position / position+velocity / velocity / acceleration, with yaw or yaw
           rate), holding position when there is none; velocity and acceleration targets
           expire after GUID_TIMEOUT (3 s) and the copter stops and holds.
  LOITER   holds the position where it was entered.
  AUTO     the stored mission (auto.py, auto_commands.py; the copter's side in copter_auto.py).
  RTL      climbs to RTL_ALT (or stays higher), flies home or to the nearest rally point
           (rally.py), waits RTL_LOIT_TIME above it, then lands and disarms (or, with
           RTL_ALT_FINAL > 0, descends to that height and hovers).
  LAND     descends at LAND_SPEED (WPNAV_SPEED_DN / LAND_SPEED_HIGH above 10 m) over the point
           where it was entered, disarms once landed.
  STABILIZE with no RC: level attitude (zero horizontal acceleration) at constant altitude.
DISARM_DELAY: disarms after that long landed without a takeoff in progress, as ArduPilot's
auto-disarm does with throttle at zero.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames.batch import wrap_pi
from vehicle.autopilot import modes
from vehicle.autopilot.base import (ACCEPTED, DENIED, FAILED, SEV_INFO, SEV_WARNING, Autopilot,
                                    UNSUPPORTED)
from vehicle.autopilot.battery import MOTOR_EFFICIENCY
from vehicle.autopilot.copter_auto import CopterAutoFlight
from vehicle.autopilot.copter_modes import CopterModes
from vehicle.autopilot.guided import GuidedTarget

LAND_ALT_LOW = 10.0     # m: below it LAND descends at LAND_SPEED


class CopterAutopilot(CopterModes, CopterAutoFlight, Autopilot):
    kind = "copter"
    mav_type = mav.MAV_TYPE_QUADROTOR
    mode_names = modes.COPTER_MODES
    supported = modes.COPTER_SUPPORTED
    armable = modes.COPTER_ARMABLE
    needs_position = modes.COPTER_NEEDS_POSITION
    guided_mode = modes.GUIDED
    auto_mode = modes.AUTO
    rtl_mode = modes.RTL
    follow_mode = modes.FOLLOW
    max_speed = 20.0      # m/s: WPNAV_SPEED's maximum
    initial_mode = modes.STABILIZE

    def __init__(self, *a, **kw) -> None:
        self.takeoff_alt: float | None = None     # world z target of an active takeoff
        self.rtl_stage = ""
        self.rtl_dest = np.zeros(3)
        self.rtl_z = 0.0
        self.rtl_loiter_t0 = 0.0
        self.landed_since: float | None = None
        super().__init__(*a, **kw)

    # ArduCopter's FailsafeAction priorities, highest first: TERMINATE, LAND, RTL,
    # SMARTRTL_LAND, SMARTRTL, NONE
    failsafe_priorities = (5, 1, 2, 4, 3, 0)

    def electrical_load(self) -> float:
        """The rotors' shaft power over the motor and ESC efficiency (W): drains with thrust."""
        return self.fleet.rotor_power(self.i) / MOTOR_EFFICIENCY

    def battery_failsafe_action(self, action: int) -> None:
        """Copter::handle_battery_failsafe: landed, disarm ("Battery Failsafe - Disarming");
        else "Battery Failsafe" and BATT_FS_*_ACT: 1 Land, 2 RTL or Land, 3 SmartRTL or RTL
        (or Land), 4 SmartRTL or Land, 5 Terminate (disarm), 6 DO_LAND_START or RTL (no
        landing sequence here: RTL or Land), 7 Brake or Land."""
        if self.on_ground and self.takeoff_alt is None:
            self.disarm(force=True)
            self.text(SEV_WARNING, "Battery Failsafe - Disarming")
            return
        self.text(SEV_WARNING, "Battery Failsafe")
        why = "battery failsafe"
        if action == 5:
            self.disarm(force=True)
            return
        chain = {1: (modes.LAND,), 2: (modes.RTL, modes.LAND),
                 3: (mav.COPTER_MODE_SMART_RTL, modes.RTL, modes.LAND),
                 4: (mav.COPTER_MODE_SMART_RTL, modes.LAND), 6: (modes.RTL, modes.LAND),
                 7: (mav.COPTER_MODE_BRAKE, modes.LAND)}.get(action, ())
        for m in chain:
            if self.mode == m or self.set_mode(m, why):
                return

    def enter_mode(self, number: int) -> None:
        super().enter_mode(number)
        self.takeoff_alt = None
        if number == modes.RTL:
            self.rtl_start()
        if number == modes.LAND:
            self.text(SEV_INFO, "Landing")
        self.enter_extra_mode(number)

    def may_disarm(self) -> bool:
        return self.on_ground

    def on_armed(self) -> None:
        self.landed_since = self.t
        if self.mode == modes.AUTO and int(self.params.get("AUTO_OPTIONS", 0)) & 2:
            self.auto.auto_armed = True       # AllowTakeOffWithoutRaisingThrottle

    def mode_armable(self) -> bool:
        """AUTO is armable only with AUTO_OPTIONS bit 0 (AllowArming), as ArduCopter."""
        if self.mode == modes.AUTO:
            return bool(int(self.params.get("AUTO_OPTIONS", 0)) & 1)
        return super().mode_armable()

    def accept_target(self, tgt) -> bool:
        """GUIDED: a destination outside an enabled fence is ignored (ArduPilot logs
        DEST_OUTSIDE_FENCE and keeps flying its previous target)."""
        if tgt.pos is not None and not self.fence.destination_ok(tgt.pos):
            return False
        return super().accept_target(tgt)

    def on_disarmed(self) -> None:
        self.takeoff_alt = None
        self.setpoint()

    # ----- takeoff / land --------------------------------------------------------------
    def vehicle_command(self, cmd, p, frame, x, y) -> int:
        if cmd == mav.MAV_CMD_NAV_TAKEOFF:
            alt = p[6]
            if (not self.armed or not self.on_ground or self.mode != modes.GUIDED
                    or not math.isfinite(alt) or alt <= 0 or alt > 1000):
                return FAILED
            self.takeoff_alt = self.pos[2] - alt
            self.target = None
            self.hold_pos = np.array([self.pos[0], self.pos[1], self.takeoff_alt])
            self.hold_yaw = self.yaw
            self.echo = GuidedTarget("pos", self.hold_pos.copy(), None, None, self.hold_yaw, None)
            self.text(SEV_INFO, f"Takeoff to {alt:.1f} m")
            self.auto.auto_armed = True
            return ACCEPTED
        if cmd == mav.MAV_CMD_NAV_LAND:
            return ACCEPTED if self.set_mode(modes.LAND) else FAILED
        if cmd == mav.MAV_CMD_NAV_LOITER_UNLIM:
            return ACCEPTED if self.set_mode(modes.LOITER) else FAILED
        if cmd == mav.MAV_CMD_CONDITION_YAW:
            # ArduPilot: angle 0..360 deg and param4 0 (absolute) or 1 (relative), else DENIED;
            # a rate (deg/s) beyond ATC_RATE_Y_MAX's range is refused too
            if (not all(math.isfinite(v) for v in p[:4]) or not 0 <= p[0] <= 360 or not 0 <= p[1] <= 1080
                    or p[3] not in (0, 1)):
                return DENIED
            if self.mode != modes.GUIDED:
                return FAILED
            ang = math.radians(p[0])
            if p[3]:
                ang = self.yaw + (ang if p[2] >= 0 else -ang)
            self.hold_yaw = wrap_pi(ang)
            if self.target is not None:
                self.target.yaw = self.hold_yaw
            return ACCEPTED
        return UNSUPPORTED

    def landed_state(self) -> int:
        if not self.armed:
            return mav.MAV_LANDED_STATE_ON_GROUND
        auto_sub = self.auto.sub if self.mode == modes.AUTO else ""
        if self.takeoff_alt is not None or (auto_sub == "takeoff" and self.auto.auto_armed):
            return mav.MAV_LANDED_STATE_TAKEOFF
        if self.on_ground:
            return mav.MAV_LANDED_STATE_ON_GROUND
        if (self.mode == modes.LAND or auto_sub == "land" or self.srtl_stage == "land"
                or ((self.mode == modes.RTL or auto_sub == "rtl") and self.rtl_stage == "land")):
            return mav.MAV_LANDED_STATE_LANDING
        return mav.MAV_LANDED_STATE_IN_AIR

    def apply_speed(self) -> None:
        if self.speed_override is not None:
            self.push_params({"WPNAV_SPEED": self.speed_override * 100.0})
        else:
            self.push_params({"WPNAV_SPEED": float(self.params.get("WPNAV_SPEED", 500))})

    # ----- failsafe ------------------------------------------------------------------
    def gcs_failsafe_action(self, enable: int) -> None:
        if self.on_ground and self.takeoff_alt is None:
            self.text(SEV_WARNING, "GCS Failsafe")
            self.disarm(force=True, reason="GCS failsafe")
            return
        if enable == 5:
            self.text(SEV_WARNING, "GCS Failsafe On: LAND")
            self.set_mode(modes.LAND, "GCS failsafe")
        elif enable == 3:
            self.text(SEV_WARNING, "GCS Failsafe On: SmartRTL")
            if not self.smart_rtl_or_rtl("GCS failsafe"):
                self.set_mode(modes.LAND, "GCS failsafe")
        elif enable == 4:
            self.text(SEV_WARNING, "GCS Failsafe On: SmartRTL")
            self.smart_rtl_or_land("GCS failsafe")
        else:
            self.text(SEV_WARNING, "GCS Failsafe On: RTL")
            if not self.set_mode(modes.RTL, "GCS failsafe"):
                self.set_mode(modes.LAND, "GCS failsafe")

    # ----- the mode loop ---------------------------------------------------------------
    def run_mode(self, dt: float) -> None:
        if self.mode == modes.AUTO:
            self.auto.run(dt)          # the mission runs disarmed too, as ArduCopter's
            return
        if not self.armed:
            self.setpoint()
            return
        if self.on_ground and self.takeoff_alt is None:
            if self.mode in (modes.LAND, modes.RTL, modes.SMART_RTL) and self.t - self.arm_time > 1.0:
                self.disarm(force=True, reason="landed")
                return
            self.ground_idle()         # idle on the ground until a takeoff
            return
        self.landed_since = None
        m = self.mode
        if self.run_extra_mode(m, dt):         # BRAKE, ALT_HOLD, POSHOLD, SMART_RTL (copter_modes.py)
            return
        if m == modes.GUIDED:
            self._guided()
        elif m == modes.LOITER:
            self.setpoint(pos=self.hold_pos, yaw=self.hold_yaw)
        elif m == modes.LAND:
            self._land(dt)
        elif m == modes.RTL:
            self._rtl(dt)
        elif m == modes.FOLLOW:
            self._follow()
        else:  # STABILIZE without RC: level, altitude and yaw held, horizontal drift free
            self.setpoint(level=True, yaw=self.hold_yaw)
            self.echo = GuidedTarget("acc", None, None, np.zeros(3), self.hold_yaw, None)

    def _guided(self) -> None:
        if self.takeoff_alt is not None:
            if self.pos[2] <= self.takeoff_alt + 0.3 or self.target is not None:
                self.takeoff_alt = None
        tgt = self.target
        if tgt is not None and self.guided_timed_out():
            self.target = None
            self.hold_here()
            tgt = None
        if tgt is None:
            self.setpoint(pos=self.hold_pos, yaw=self.hold_yaw)
            return
        yaw = tgt.yaw if tgt.yaw is not None else (None if tgt.yaw_rate is not None else self.hold_yaw)
        if tgt.yaw is not None:
            self.hold_yaw = tgt.yaw
        elif tgt.yaw_rate is not None:
            self.hold_yaw = self.yaw
        self.setpoint(pos=tgt.pos, vel=tgt.vel, acc=tgt.acc, yaw=yaw, yaw_rate=tgt.yaw_rate)

    def _follow(self) -> None:
        """FOLLOW: the lead's velocity plus FOLL_POS_P times the offset error, within WPNAV's
        limits (vehicle/autopilot/follow_mode.py); no valid lead: stop and hold."""
        p = self.params
        cmd = self.follow.command(self.t, self.pos, float(p.get("WPNAV_SPEED", 500)) / 100.0,
                                  float(p.get("WPNAV_ACCEL", 250)) / 100.0,
                                  (float(p.get("WPNAV_SPEED_UP", 250)) / 100.0,
                                   float(p.get("WPNAV_SPEED_DN", 150)) / 100.0))
        if cmd is None:
            self.setpoint(yaw=self.hold_yaw)
            self.echo = GuidedTarget("vel", None, np.zeros(3), None, self.hold_yaw, None)
            return
        if cmd.yaw is not None:
            self.hold_yaw = cmd.yaw
        self.setpoint(vel=cmd.vel, yaw=self.hold_yaw)
        self.echo = GuidedTarget("vel", None, cmd.vel, None, self.hold_yaw, None)

    def _descent_speed(self) -> float:
        home_z = self.home[2] if self.home is not None else 0.0
        alt = home_z - self.pos[2]
        if alt > float(self.params.get("LAND_ALT_LOW", 100 * LAND_ALT_LOW)) / 100.0:
            hi = float(self.params.get("LAND_SPEED_HIGH", 0)) or float(self.params.get("WPNAV_SPEED_DN", 150))
            return hi / 100.0
        return float(self.params.get("LAND_SPEED", 50)) / 100.0

    def _land(self, dt: float) -> None:
        speed = self._descent_speed()
        x, y = self.hold_pos[0], self.hold_pos[1]
        self.echo = GuidedTarget("posvel", np.array([x, y, self.pos[2]]), np.array([0.0, 0.0, speed]),
                                 None, self.hold_yaw, None)
        self.setpoint(pos=np.array([x, y, np.nan]), vel=np.array([0.0, 0.0, speed]), yaw=self.hold_yaw)

    def _rtl(self, dt: float) -> None:
        home = self.rtl_dest             # home, or the rally point chosen at RTL's start
        if self.rtl_stage == "climb":
            tgt = np.array([self.hold_pos[0], self.hold_pos[1], self.rtl_z])
            if abs(self.pos[2] - self.rtl_z) < 0.5:
                self.rtl_stage = "return"
        if self.rtl_stage == "return":
            tgt = np.array([home[0], home[1], self.rtl_z])
            if np.linalg.norm(self.pos[:2] - home[:2]) < 0.5 and np.linalg.norm(self.vel) < 0.3:
                self.rtl_stage = "loiter"          # RTL_LOIT_TIME above home, then down
                self.rtl_loiter_t0 = self.t
                self.hold_pos = np.array([home[0], home[1], self.pos[2]])
        if self.rtl_stage == "loiter":
            tgt = self.hold_pos.copy()
            if self.t - self.rtl_loiter_t0 >= float(self.params.get("RTL_LOIT_TIME", 5000)) / 1000.0:
                final = float(self.params.get("RTL_ALT_FINAL", 0)) / 100.0
                self.rtl_stage = "final" if final > 0 else "land"
        if self.rtl_stage == "final":              # RTL_ALT_FINAL > 0: hover there, stay in RTL
            home_z = self.home[2] if self.home is not None else home[2]
            tgt = np.array([home[0], home[1], home_z - float(self.params.get("RTL_ALT_FINAL", 0)) / 100.0])
        if self.rtl_stage == "land":
            self._land(dt)
            return
        self.echo = GuidedTarget("pos", tgt, None, None, self.hold_yaw, None)
        self.setpoint(pos=tgt, yaw=self.hold_yaw)
