"""The crash check of one autopilot (ArduCopter/crash_check.cpp Copter::crash_check, run from
update_land_and_crash_detectors every main loop): a copter that has lost its attitude and lies
still disarms itself instead of spinning its motors into the ground.

Copter (CopterCrashCheck), each tick, all of these or the count starts again:
- armed, not landed (the land detector), FS_CRASH_CHECK != 0 (default 1), in a mode whose
  crash_check_enabled() (ArduCopter: not ACRO, not FLIP; towerlink has neither);
- the 1 Hz low-passed earth-frame acceleration, gravity taken out, below
  CRASH_CHECK_ACCEL_MAX (3 m/s/s): ArduCopter filters the accelerometers' specific force
  rotated to the earth frame plus g; here the estimate's velocity change per tick, the same
  kinematic acceleration (a falling copter reads ~g and is not yet crashed);
- leaning more than CRASH_CHECK_ANGLE_MIN_DEG (15 deg) from level (estimated attitude);
- the attitude controller's error more than CRASH_CHECK_ANGLE_DEVIATION_DEG (30 deg):
  AC_AttitudeControl's get_att_error_angle_deg, the angle between the target's and the
  estimate's thrust axes (yaw does not count);
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
ACCEL_FILTER_HZ = 1.0            # land_accel_ef_filter's cut-off
THRUST_LOSS_TRIGGER_SEC = 1.0    # THRUST_LOSS_CHECK_TRIGGER_SEC
THRUST_LOSS_ANGLE_DEG = 15.0     # THRUST_LOSS_CHECK_ANGLE_DEVIATION_CD / 100
THRUST_LOSS_MIN_THROTTLE = 0.9   # THRUST_LOSS_CHECK_MINIMUM_THROTTLE
MOTOR_FILTER_S = 0.5             # check_for_failed_motor's filter time constant
_COS_LEAN_MIN = math.cos(math.radians(ANGLE_MIN_DEG))


def lean_cos(quat) -> float:
    """cos of the lean from level of an (x, y, z, w) body FRD -> world NED quaternion:
    ArduPilot's cos_roll() * cos_pitch(), the thrust axis' vertical component."""
    qx, qy = float(quat[0]), float(quat[1])
    return 1.0 - 2.0 * (qx * qx + qy * qy)


def thrust_error_angle_deg(quat, tan_roll: float, tan_pitch: float, yaw: float) -> float:
    """Degrees between the thrust axis (body z) of the attitude target -- ZYX Euler roll and
    pitch given by their tangents, heading `yaw` rad -- and that of the (x, y, z, w)
    quaternion `quat` (body FRD -> world NED): AC_AttitudeControl's thrust error angle."""
    qx, qy, qz, qw = (float(v) for v in quat)
    cp = 1.0 / math.sqrt(1.0 + tan_pitch * tan_pitch)
    sp = tan_pitch * cp
    cr = 1.0 / math.sqrt(1.0 + tan_roll * tan_roll)
    sr = tan_roll * cr
    cy, sy = math.cos(yaw), math.sin(yaw)
    # third column of Rz(yaw) Ry(pitch) Rx(roll), and of the quaternion's rotation
    tx, ty, tz = cy * sp * cr + sy * sr, sy * sp * cr - cy * sr, cp * cr
    bx, by, bz = 2.0 * (qx * qz + qw * qy), 2.0 * (qy * qz - qw * qx), 1.0 - 2.0 * (qx * qx + qy * qy)
    dot = max(-1.0, min(1.0, tx * bx + ty * by + tz * bz))
    return math.degrees(math.acos(dot))


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
        self.accel = (0.0, 0.0, 0.0)            # 1 Hz filtered acceleration, m/s/s NED
        self._last_vel: tuple[float, float, float] | None = None
        self.losing_s = 0.0                     # s the thrust loss conditions have held
        self.thrust_boost = False               # AP_Motors' thrust boost (latched by the check)
        self._thrust: list[float] | None = None  # the motors' filtered thrust commands (0..1)

    def update(self, dt: float) -> None:
        ap = self.ap
        if not ap.armed:
            self.crashing_s, self.accel, self._last_vel = 0.0, (0.0, 0.0, 0.0), None
            self.losing_s, self.thrust_boost, self._thrust = 0.0, False, None
            return
        acc = self._filter_accel(dt)
        self._thrust_loss(dt)
        if (ap.on_ground or not int(ap.params.get("FS_CRASH_CHECK", 1))
                or not ap.flightmode.crash_check_enabled()):
            self.crashing_s = 0.0
            return
        if acc >= ACCEL_MAX or lean_cos(ap.quat) >= _COS_LEAN_MIN:
            self.crashing_s = 0.0
            return
        c = controller_row(ap.fleet, ap.i)      # only now: most ticks end above
        err = thrust_error_angle_deg(ap.quat, c.tan_roll_t, c.tan_pitch_t, c.yaw)
        vx, vy, vz = ap.vel.tolist()
        if err <= ANGLE_DEVIATION_DEG or vx * vx + vy * vy + vz * vz >= SPEED_MAX * SPEED_MAX:
            self.crashing_s = 0.0
            return
        self.crashing_s += dt
        if self.crashing_s >= TRIGGER_SEC - 1e-9:
            ap.text(mav.MAV_SEVERITY_EMERGENCY,
                    f"Crash: Disarming: AngErr={err:.0f}>{ANGLE_DEVIATION_DEG:.0f}, Accel={acc:.1f}<{ACCEL_MAX:.1f}")
            ap.disarm(force=True, reason="crash")

    def _filter_accel(self, dt: float) -> float:
        """Step land_accel_ef_filter (a first-order low-pass at ACCEL_FILTER_HZ, ArduPilot's
        LowPassFilter) on the estimated velocity's change; its magnitude, m/s/s."""
        vel = tuple(self.ap.vel.tolist())
        last, self._last_vel = self._last_vel, vel
        if last is None or dt <= 0:
            return math.sqrt(sum(a * a for a in self.accel))
        alpha = dt / (dt + 1.0 / (2.0 * math.pi * ACCEL_FILTER_HZ))
        ax, ay, az = self.accel
        ax += ((vel[0] - last[0]) / dt - ax) * alpha
        ay += ((vel[1] - last[1]) / dt - ay) * alpha
        az += ((vel[2] - last[2]) / dt - az) * alpha
        self.accel = (ax, ay, az)
        return math.sqrt(ax * ax + ay * ay + az * az)

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
                or thrust_error_angle_deg(ap.quat, tr, tp, c.yaw) >= ANGLE_DEVIATION_DEG):
            self.losing_s = 0.0
            return
        self.losing_s += dt
        if self.losing_s >= THRUST_LOSS_TRIGGER_SEC - 1e-9:
            self.losing_s = 0.0
            self.thrust_boost = True
            lost = self._thrust.index(high) + 1
            ap.text(mav.MAV_SEVERITY_EMERGENCY, f"Potential Thrust Loss ({lost})")
