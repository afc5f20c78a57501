"""The crash check of one autopilot (ArduCopter/crash_check.cpp Copter::crash_check, run from
update_land_and_crash_detectors every main loop): a copter that has lost its attitude and lies
still disarms itself instead of spinning its motors into the ground.

Copter (CopterCrashCheck), each tick, all of these or the count starts again:
- armed, not landed (the land detector), FS_CRASH_CHECK != 0 (default 1), in a mode whose
  crash_check_enabled() (ArduCopter: not ACRO, not FLIP; towerlink has neither);
- the 1 Hz low-passed earth-frame acceleration, gravity taken out (land_accel_ef_filter: the
  land detector's, vehicle.fleet._land_detect keeps it in the controller's lax, lay, laz),
  below CRASH_CHECK_ACCEL_MAX (3 m/s/s) (a falling copter reads ~g and is not yet crashed);
- leaning more than CRASH_CHECK_ANGLE_MIN_DEG (15 deg) from level (estimated attitude);
- the attitude controller's error more than CRASH_CHECK_ANGLE_DEVIATION_DEG (30 deg):
  AC_AttitudeControl's get_att_error_angle_deg, the angle between the target's and the
  estimate's thrust axes (yaw does not count; the controller's att_err);
- slower than CRASH_CHECK_SPEED_MAX (10 m/s) (estimated velocity).
CRASH_CHECK_TRIGGER_SEC (2 s) of that: EMERGENCY "Crash: Disarming: AngErr=<e>>30,
Accel=<a><3.0" (ArduCopter's words and format), the ARM record's Method CRASH (12), disarm.
ArduCopter also logs ERR (CRASH_CHECK, CRASH_CHECK_CRASH); towerlink's log has no ERR yet.

The thrust loss check (Copter::thrust_loss_check), each tick, all of these or the count starts
again: armed, not landed, thrust boost not already on; the attitude target within
THRUST_LOSS_ANGLE_DEG (15 deg) of level (roll and pitch together); the collective at least
THRUST_LOSS_MIN_THROTTLE (0.9) or a motor at full output, and at least 0.25; descending; the
attitude error under 30 deg. THRUST_LOSS_TRIGGER_SEC (1 s) of that: EMERGENCY "Potential
Thrust Loss (<n>)", n the motor commanded hardest (0.5 s filtered, AP_MotorsMatrix's lost
motor), and thrust boost on; it goes off once no motor is commanded above 0.9 of full thrust.
What the boost changes in ArduPilot's mixer (the lost motor's share given up) is not modelled.
Rover: no crash check here (ArduRover's FS_CRASH_CHECK, default off, is not modelled).
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

TRIGGER_SEC = 2.0                # CRASH_CHECK_TRIGGER_SEC
ANGLE_DEVIATION_DEG = 30.0       # CRASH_CHECK_ANGLE_DEVIATION_DEG: attitude error
ANGLE_MIN_DEG = 15.0             # CRASH_CHECK_ANGLE_MIN_DEG: lean from level
SPEED_MAX = 10.0                 # CRASH_CHECK_SPEED_MAX, m/s
ACCEL_MAX = 3.0                  # CRASH_CHECK_ACCEL_MAX, m/s/s
THRUST_LOSS_TRIGGER_SEC = 1.0    # THRUST_LOSS_CHECK_TRIGGER_SEC
THRUST_LOSS_ANGLE_DEG = 15.0     # THRUST_LOSS_CHECK_ANGLE_DEVIATION_CD / 100
THRUST_LOSS_MIN_THROTTLE = 0.9   # THRUST_LOSS_CHECK_MINIMUM_THROTTLE
MOTOR_FILTER_S = 0.5             # check_for_failed_motor's filter time constant
_COS_LEAN_MIN = math.cos(math.radians(ANGLE_MIN_DEG))


def lean_cos(quat) -> float:
    """cos of the lean from level of an (x, y, z, w) body FRD -> world NED quaternion:
    ArduPilot's cos_roll() * cos_pitch(), the thrust axis' vertical component."""
    qx, qy = float(quat[0]), float(quat[1])
    return max(-1.0, 1.0 - 2.0 * (qx * qx + qy * qy))    # (upside down, rounding can pass -1)


def error_angle_deg(att_err: float) -> float:
    """Degrees between the target's and the estimate's thrust axes from the controller's
    att_err (sin^2 of half that angle: the error rotation's R33 is 1 - 2 att_err)."""
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * att_err))))


class _Row:
    """One vehicle's values of a batched fleet's controller arrays, read as floats on demand
    (controller_of copies every field: dear at every tick of a thousand vehicles)."""

    __slots__ = ("_arrays", "_i")

    def __init__(self, arrays, i: int) -> None:
        self._arrays, self._i = arrays, i

    def __getattr__(self, name: str) -> float:
        return float(getattr(self._arrays, name)[self._i])


def controller_row(fleet, i: int):
    """Vehicle i's controller memory (vehicle/control/copter.py CopterCtrlState fields):
    a small fleet's own object, a batched fleet's row."""
    return fleet.controller_of(i) if fleet.scalar else _Row(fleet.ctrl, i)


class CrashCheck:
    """A vehicle without a crash check (the rover): update does nothing."""

    def __init__(self, ap) -> None:
        self.ap = ap

    def update(self, dt: float) -> None:
        """Every autopilot tick (dt s since the last one)."""


class CopterCrashCheck(CrashCheck):
    """Copter::crash_check on the estimate and the attitude controller's target."""

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.crashing_s = 0.0                   # s the conditions have held (crash_counter)
        self.losing_s = 0.0                     # s the thrust loss conditions have held
        self.thrust_boost = False               # AP_Motors' thrust boost (latched by the check)
        self._thrust: list[float] | None = None  # the motors' filtered thrust commands (0..1)

    def update(self, dt: float) -> None:
        ap = self.ap
        if not ap.armed:
            self.crashing_s, self.losing_s, self.thrust_boost, self._thrust = 0.0, 0.0, False, None
            return
        self._thrust_loss(dt)
        if (ap.on_ground or not int(ap.params.get("FS_CRASH_CHECK", 1))
                or not ap.flightmode.crash_check_enabled() or lean_cos(ap.quat) >= _COS_LEAN_MIN):
            self.crashing_s = 0.0               # (the lean first: most ticks end here, cheaply)
            return
        c = controller_row(ap.fleet, ap.i)
        acc = math.sqrt(c.lax * c.lax + c.lay * c.lay + c.laz * c.laz)
        err = error_angle_deg(c.att_err)
        vx, vy, vz = ap.vel.tolist()
        if (acc >= ACCEL_MAX or err <= ANGLE_DEVIATION_DEG
                or vx * vx + vy * vy + vz * vz >= SPEED_MAX * SPEED_MAX):
            self.crashing_s = 0.0
            return
        self.crashing_s += dt
        if self.crashing_s >= TRIGGER_SEC - 1e-9:
            ap.text(mav.MAV_SEVERITY_EMERGENCY,
                    f"Crash: Disarming: AngErr={err:.0f}>{ANGLE_DEVIATION_DEG:.0f}, Accel={acc:.1f}<{ACCEL_MAX:.1f}")
            ap.disarm(force=True, reason="crash")

    def _thrust_loss(self, dt: float) -> None:
        """Copter::thrust_loss_check, with the motors' filter of check_for_failed_motor."""
        ap = self.ap
        if ap.on_ground:
            self.losing_s, self._thrust = 0.0, None
            return
        if float(ap.vel[2]) <= 0.0 and not self.thrust_boost:
            self.losing_s, self._thrust = 0.0, None     # not descending: the common case, cheap
            return
        c = controller_row(ap.fleet, ap.i)
        cmds = (c.f0 * c.f0, c.f1 * c.f1, c.f2 * c.f2, c.f3 * c.f3)    # thrust = speed squared
        last = self._thrust
        if last is None or dt <= 0:
            self._thrust = list(cmds)
        else:
            a = dt / (dt + MOTOR_FILTER_S)
            self._thrust = [t + (m - t) * a for t, m in zip(last, cmds)]
        high = max(self._thrust)
        if self.thrust_boost:
            if high < 0.9:                      # the lost motor's work is no longer needed
                self.thrust_boost = False
            return
        thr = c.coll
        if thr < 0.25 or (thr < THRUST_LOSS_MIN_THROTTLE and max(cmds) < 1.0 - 1e-9):
            self.losing_s = 0.0                 # (a hovering copter's noise ends here)
            return
        tr, tp = c.tan_roll_t, c.tan_pitch_t
        roll, pitch = math.degrees(math.atan(tr)), math.degrees(math.atan(tp))
        if (roll * roll + pitch * pitch > THRUST_LOSS_ANGLE_DEG ** 2
                or error_angle_deg(c.att_err) >= ANGLE_DEVIATION_DEG):
            self.losing_s = 0.0
            return
        self.losing_s += dt
        if self.losing_s >= THRUST_LOSS_TRIGGER_SEC - 1e-9:
            self.losing_s = 0.0
            self.thrust_boost = True
            lost = self._thrust.index(high) + 1
            ap.text(mav.MAV_SEVERITY_EMERGENCY, f"Potential Thrust Loss ({lost})")
