"""ArduCopter's BRAKE, ALT_HOLD, POSHOLD and SMART_RTL, as a mixin of CopterAutopilot.

No RC is simulated, so each mode runs as ArduCopter does with the sticks centred:
  BRAKE     stops as fast as ArduPilot's ModeBrake: horizontal deceleration
            BRAKE_MODE_DECEL_RATE (750 cm/s/s, jerk PSC_JERK_XY), altitude held; once stopped
            it holds that point. `brake_stop_time` is the time (s) from entering to stopped.
  ALT_HOLD  level attitude (roll/pitch 0), climb rate 0: the altitude at entry is held and the
            copter drifts horizontally with what momentum it has, as with the sticks centred.
  POSHOLD   sticks centred: brakes with PHLD_BRAKE_ANGLE (cdeg) / PHLD_BRAKE_RATE (deg/s)
            as its deceleration and jerk limit, then holds the point where it stopped.
  SMART_RTL retraces the SmartRTL breadcrumbs (smartrtl.py: SRTL_ACCURACY, SRTL_POINTS) at
            WPNAV_SPEED, goes 2 m above the first point (where it armed) and lands there.
            The path is recorded while armed in every other mode. Without a usable path the
            mode refuses to start ("Mode change to SMART_RTL failed: init failed"); the GCS
            failsafe then says "SmartRTL Unavailable, Trying RTL Mode" and flies RTL.
  GUIDED    DO_PAUSE_CONTINUE pauses (decelerates at WPNAV_ACCEL to a stop and holds) and
            continues the target, as ArduCopter's ModeGuided::pause()/resume().
Setpoints are world NED (see copter.py).
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.smartrtl import RecordsSmartRTLPath

BRAKE_MODE_DECEL_RATE = 750.0    # cm/s/s (ArduCopter config.h)
STOPPED_SPEED = 0.1              # m/s: below it the copter counts as stopped
GRAVITY = 9.80665
NAN = float("nan")


class CopterModes(RecordsSmartRTLPath):
    """Mixin: needs Autopilot's state (pos, vel, t, params, hold_pos, setpoint, ...)."""

    SMART_RTL_MODE = modes.SMART_RTL

    def __init__(self, *a, **kw) -> None:
        self.brake_t0 = 0.0
        self.brake_stop_time: float | None = None
        self.stopping = False          # BRAKE/POSHOLD: still decelerating
        self.srtl_stage = ""
        self.srtl_dest: np.ndarray | None = None
        self.srtl_popped: np.ndarray | None = None   # taken off the path, not yet reached
        super().__init__(*a, **kw)

    def exit_mode(self, number: int) -> None:
        if number in (modes.BRAKE, modes.POSHOLD, modes.GUIDED) and self.stopping:
            self._restore_limits()
        if number == modes.SMART_RTL and self.srtl_popped is not None:
            self.srtl.push(self.srtl_popped)          # not reached: back on the path
        self.srtl_popped = self.srtl_dest = None
        self.stopping = False
        self.srtl_stage = ""
        self.guided_paused = False
        super().exit_mode(number)

    def enter_extra_mode(self, number: int) -> None:
        """Called from CopterAutopilot.enter_mode after the hold point was set."""
        if number in (modes.BRAKE, modes.POSHOLD) and (not self.armed or self.on_ground):
            return                                    # nothing to stop: hold where it is
        if number == modes.BRAKE:
            self._start_stopping(BRAKE_MODE_DECEL_RATE / 100.0, float(self.params.get("PSC_JERK_XY", 5.0)))
        elif number == modes.POSHOLD:
            angle = math.radians(float(self.params.get("PHLD_BRAKE_ANGLE", 3000)) / 100.0)
            rate = math.radians(float(self.params.get("PHLD_BRAKE_RATE", 8)))
            self._start_stopping(GRAVITY * math.tan(angle), GRAVITY * rate)
        elif number == modes.SMART_RTL:
            self.srtl.cleanup()
            self.srtl_stage = "path"
            self.srtl_dest = None            # the first point is taken when it flies

    # ----- BRAKE / POSHOLD: stop, then hold -------------------------------------------------
    def _start_stopping(self, decel: float, jerk: float) -> None:
        """Decelerate along the current horizontal velocity with `decel` (m/s/s) reached at
        `jerk` (m/s/s/s) and eased out at the end, as a jerk-limited stop (AC_PosControl's
        stopping with these limits; the lean-angle limit ANGLE_MAX still caps it)."""
        self.brake_t0 = self.t
        self.brake_stop_time = None
        self.stopping = True
        v = np.array([self.vel[0], self.vel[1], 0.0])
        self.brake_speed = float(np.linalg.norm(v))
        self.brake_dir = v / self.brake_speed if self.brake_speed > 1e-6 else np.zeros(3)
        self.brake_acc = 0.0
        self.brake_pos = np.array([self.pos[0], self.pos[1], self.hold_pos[2]])
        self.brake_decel, self.brake_jerk = decel, jerk
        # the shaped reference must be allowed this deceleration while it follows the stop
        # (the stop's own jerk limit is in the profile below; the reference keeps PSC_JERK_XY
        # when that is higher, so it does not lag the profile)
        self.push_params({"WPNAV_ACCEL": max(decel * 100.0, float(self.params.get("WPNAV_ACCEL", 250))),
                          "PSC_JERK_XY": max(jerk, float(self.params.get("PSC_JERK_XY", 5.0)))})

    def _restore_limits(self) -> None:
        self.push_params({"WPNAV_ACCEL": float(self.params.get("WPNAV_ACCEL", 250)),
                          "PSC_JERK_XY": float(self.params.get("PSC_JERK_XY", 5.0))})

    def _stop_then_hold(self, dt: float) -> None:
        if self.stopping:
            s, j = self.brake_speed, self.brake_jerk
            # deceleration ramps up at the jerk limit, and down again so the speed reaches 0
            # with zero acceleration (a <= sqrt(2 j s))
            a = min(self.brake_decel, self.brake_acc + j * dt, math.sqrt(2.0 * j * max(s, 0.0)))
            self.brake_acc = a
            s_new = max(0.0, s - a * dt)
            self.brake_pos = self.brake_pos + self.brake_dir * 0.5 * (s + s_new) * dt
            self.brake_speed = s = s_new
            if s <= 0.0 and float(np.linalg.norm(self.vel[:2])) < STOPPED_SPEED:
                self.stopping = False
                self.brake_stop_time = self.t - self.brake_t0
                self._restore_limits()
                # hold where it stopped (within a few cm of the profile's stopping point)
                self.hold_pos = np.array([self.pos[0], self.pos[1], self.hold_pos[2]])
            else:
                # the stopping trajectory as position + velocity + acceleration, so the
                # position loop corrects the lag as ArduPilot's brake (a stopping point) does
                vel, acc = self.brake_dir * s, -self.brake_dir * (a if s > 0 else 0.0)
                self.echo = GuidedTarget("posvel", self.brake_pos.copy(), vel, acc, self.hold_yaw, None)
                self.setpoint(pos=self.brake_pos.copy(), vel=vel, acc=acc, yaw=self.hold_yaw)
                return
        self.echo = GuidedTarget("pos", self.hold_pos.copy(), None, None, self.hold_yaw, None)
        self.setpoint(pos=self.hold_pos, yaw=self.hold_yaw)

    # ----- SMART_RTL --------------------------------------------------------------------------
    def _srtl_next(self) -> None:
        p = self.srtl_popped = self.srtl.pop()
        if p is None or not self.srtl.points:
            # the last point (where it armed): 2 m above it, then land there
            dest = self.pos.copy() if p is None else p.copy()
            dest[2] -= 2.0
            self.srtl_dest = dest
            self.srtl_stage = "preland"
        else:
            self.srtl_dest = p

    def _smart_rtl(self, dt: float) -> None:
        if self.srtl_stage == "land":
            self._land(dt)
            return
        if self.srtl_dest is None:
            self._srtl_next()
        radius = max(float(self.params.get("WPNAV_RADIUS", 200)) / 100.0, 0.5)
        dest = self.srtl_dest
        if np.linalg.norm(self.pos - dest) < radius:
            if self.srtl_stage == "preland":
                if np.linalg.norm(self.vel) < 0.5:
                    self.srtl_stage = "land"
                    self.srtl_popped = None
                    self.hold_pos = np.array([dest[0], dest[1], self.pos[2]])
                    self._land(dt)
                    return
            else:
                self._srtl_next()
                dest = self.srtl_dest
        self.echo = GuidedTarget("pos", dest.copy(), None, None, self.hold_yaw, None)
        self.setpoint(pos=dest, yaw=self.hold_yaw)

    # ----- GUIDED pause (ArduCopter ModeGuided::pause/resume) ----------------------------------
    guided_paused = False

    def guided_pause(self, pause: bool) -> bool:
        if self.mode != modes.GUIDED:
            return False
        if pause and not self.guided_paused:
            self.guided_paused = True
            self.hold_here()
            if self.armed and not self.on_ground:     # decelerate to a stop, then hold there
                self._start_stopping(float(self.params.get("WPNAV_ACCEL", 250)) / 100.0,
                                     float(self.params.get("PSC_JERK_XY", 5.0)))
        elif not pause:
            if self.stopping:
                self._restore_limits()
                self.stopping = False
            self.guided_paused = False
            self.target_time = self.t                 # the target's timeout restarts
        return True

    # ----- the loop ------------------------------------------------------------------------
    def run_extra_mode(self, m: int, dt: float) -> bool:
        """Setpoints for the modes of this module (armed, in the air); False for other modes."""
        if (m == modes.GUIDED and self.guided_paused) or m in (modes.BRAKE, modes.POSHOLD):
            self._stop_then_hold(dt)
        elif m == modes.ALT_HOLD:
            self.echo = GuidedTarget("acc", None, None, np.zeros(3), self.hold_yaw, None)
            self.setpoint(pos=np.array([NAN, NAN, self.hold_pos[2]]), level=True, yaw=self.hold_yaw)
        elif m == modes.SMART_RTL:
            self._smart_rtl(dt)
        else:
            return False
        return True

    def smart_rtl_or_rtl(self, reason: str) -> bool:
        """ArduCopter's set_mode_SmartRTL_or_RTL: SMART_RTL, else RTL with its text."""
        if self.set_mode(modes.SMART_RTL, reason):
            return True
        self.text(mav.MAV_SEVERITY_WARNING, "SmartRTL Unavailable, Trying RTL Mode")
        return self.set_mode(modes.RTL, reason)

    def fence_action_copter(self, action: int, far_outside: bool) -> None:
        """FENCE_ACTION 3 SmartRTL or RTL or LAND, 4 BRAKE or LAND, 5 SmartRTL or LAND (ArduCopter's
        fence_check); 1, 2, landed and more than 100 m outside: as copter_auto.py does."""
        if self.on_ground or far_outside or action not in (3, 4, 5):
            super().fence_action_copter(action, far_outside)
        elif action == 3:
            if not self.smart_rtl_or_rtl("fence breach"):
                self.set_mode(modes.LAND, "fence breach")
        elif action == 4:
            if not self.set_mode(modes.BRAKE, "fence breach"):
                self.set_mode(modes.LAND, "fence breach")
        else:
            self.smart_rtl_or_land("fence breach")

    def smart_rtl_or_land(self, reason: str) -> bool:
        if self.set_mode(modes.SMART_RTL, reason):
            return True
        self.text(mav.MAV_SEVERITY_WARNING, "SmartRTL Unavailable, Using Land Mode")
        return self.set_mode(modes.LAND, reason)
