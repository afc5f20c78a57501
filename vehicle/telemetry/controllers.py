"""What the controllers ask for: PID_TUNING and ATTITUDE_TARGET.

PID_TUNING (GCS_MAVLINK_Copter::send_pid_tuning; SR0_EXTRA1, axes chosen by GCS_PID_MASK):
- Copter 1 roll, 2 pitch, 4 yaw: the rate controller of that body axis (ATC_RAT_*):
  desired = the body-rate target and achieved = the estimated rate it was compared with
  (rad/s, as ArduPilot's AC_PID works in rad/s), P = ATC_RAT_*_P x error, I = the
  integrator, D = ATC_RAT_*_D x the filtered error derivative, all in the controller's
  normalised torque. FF 0 (no ATC_RAT_*_FF term is simulated), SRate 0 (no slew limiter),
  PDmod 1 (no slew-rate modifier applied).
- Copter 8 accel z: desired = the vertical acceleration the position controller asks for,
  achieved = the estimate's vertical acceleration (cm/s^2, up positive, as AC_PosControl's
  accel PID in 4.5). Approximated: towerlink has no acceleration PID (the collective is
  computed from the target directly), so P, I and D are 0 and FF is the desired value.
- Rover 1 steering rate (PID_TUNING_STEER, deg/s as GCS_MAVLINK_Rover sends it): desired =
  the turn rate the steering asked for, achieved = the turn rate; 2 speed (PID_TUNING_ACCZ,
  m/s): desired = the commanded speed, achieved = the speed. Approximated: the simulated
  drive follows its commands through its own lag, with no PID, so FF = desired and
  P = I = D = 0.
Every enabled axis is sent each time the message is due, in that order, one PID_TUNING
per axis (send_pid_tuning loops over the axes; each is guarded by HAVE_PAYLOAD_SPACE, which a
network link always has): with n axes enabled each arrives at SR0_EXTRA1's rate (or at
PID_TUNING's SET_MESSAGE_INTERVAL), n messages a slot.

ATTITUDE_TARGET (GCS_MAVLINK_Copter::send_attitude_target; in no stream group, asked for by
SET_MESSAGE_INTERVAL or REQUEST_MESSAGE, in every mode): the attitude controller's target
quaternion (roll and pitch the lean asked for, yaw the heading reference), the body-rate
target (rad/s) and the collective thrust (0..1), type_mask 0. ArduRover does not send it.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames import quaternion_from_euler
from vehicle.telemetry.wire import boot_ms

_COPTER_AXES = ((1, mav.PID_TUNING_ROLL), (2, mav.PID_TUNING_PITCH), (4, mav.PID_TUNING_YAW),
                (8, mav.PID_TUNING_ACCZ))
_ROVER_AXES = ((1, mav.PID_TUNING_STEER), (2, mav.PID_TUNING_ACCZ))


class ControllerTelemetry:
    """PID_TUNING and ATTITUDE_TARGET of one vehicle (`ap`: its autopilot; clock: sim s)."""

    def __init__(self, ap, clock) -> None:
        self.ap = ap
        self.clock = clock

    def pid_tuning_fields(self) -> list[tuple] | None:
        """One PID_TUNING's fields per enabled axis (GCS_PID_MASK), in ArduPilot's axis
        order; None with none enabled."""
        ap = self.ap
        mask = int(ap.params.get("GCS_PID_MASK", 0) or 0)
        if not mask:
            return None
        copter = ap.kind == "copter"
        one = self._copter_axis if copter else self._rover_axis
        out = [one(a) for bit, a in (_COPTER_AXES if copter else _ROVER_AXES) if mask & bit]
        return out or None

    def _copter_axis(self, axis: int) -> tuple:
        ap = self.ap
        c = ap.fleet.controller_of(ap.i)
        if axis == mav.PID_TUNING_ACCZ:
            want = -c.atz * 100.0
            got = -float(ap.fleet.estimate(ap.i).acc[2]) * 100.0
            return (axis, want, got, want, 0.0, 0.0, 0.0, 0.0, 1.0)
        k = axis - mav.PID_TUNING_ROLL
        target = (c.rtx, c.rty, c.rtz)[k]
        err = (c.erx, c.ery, c.erz)[k]
        integ = (c.irx, c.iry, c.irz)[k]
        deriv = (c.drx, c.dry, c.drz)[k]
        kp, _, kd, _ = ap.fleet.gains_of(ap.i).rat[k]
        return (axis, target, target - err, 0.0, kp * err, integ, kd * deriv, 0.0, 1.0)

    def _rover_axis(self, axis: int) -> tuple:
        fleet, i = self.ap.fleet, self.ap.i
        v_cmd, speed, rate = fleet.drive_outputs(i)
        if axis == mav.PID_TUNING_STEER:
            want, got = math.degrees(fleet.turn_command(i)), math.degrees(rate)
        else:
            want, got = v_cmd, speed
        return (axis, want, got, want, 0.0, 0.0, 0.0, 0.0, 1.0)

    def attitude_target_fields(self) -> tuple | None:
        ap = self.ap
        if ap.kind != "copter":
            return None
        c = ap.fleet.controller_of(ap.i)
        x, y, z, w = quaternion_from_euler(math.atan(c.tan_roll_t), math.atan(c.tan_pitch_t), c.yaw)
        return (boot_ms(self.clock()), 0, [w, x, y, z], c.rtx, c.rty, c.rtz, float(c.coll))
