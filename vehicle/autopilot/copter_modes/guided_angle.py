"""GUIDED's attitude control (ArduCopter/mode_guided.cpp: angle_control_start, set_angle,
angle_control_run), flown by GUIDED after a SET_ATTITUDE_TARGET and always by GUIDED_NOGPS.

What it flies (learned from ArduCopter's source, re-expressed here):
- The target attitude (roll, pitch, yaw) with body-rate feed-forward, or the body rates
  alone; either way the target attitude moves at those rates between messages, as
  AC_AttitudeControl's input_quaternion / input_rate_bf_roll_pitch_yaw advance it. There is
  no horizontal position control: the copter drifts with what its lean gives it.
- Vertically a climb rate (WPNAV_SPEED_UP / _DN bound it), or with GUID_OPTIONS bit 3 the
  thrust as throttle.
- No new target for GUID_TIMEOUT s (at least 0.1 s): level at the target's heading, rates
  zero, climb rate zero (a thrust target goes back to climb-rate control); no STATUSTEXT.
- A positive climb rate or thrust while armed sets "auto armed"; on the ground it takes
  off; with none it idles there (and DISARM_DELAY still disarms).
- POSITION_TARGET_LOCAL_NED is not sent while it flies (ArduCopter's Angle sub-mode).

Angles rad (ZYX Euler, world NED), rates rad/s (body FRD), climb m/s up. towerlink's
controller flies roll and pitch within +-80 deg (vehicle/fleet.py MAX_LEAN): no flips.
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import wrap_pi
from vehicle.autopilot.attitude_target import AttitudeTarget
from vehicle.fleet import MAX_LEAN

MIN_TIMEOUT_S = 0.1          # ModeGuided::get_timeout_ms's floor
ZERO_RATES = (0.0, 0.0, 0.0)


class GuidedAngle:
    """The attitude control of one copter's GUIDED (or GUIDED_NOGPS)."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self.active = False
        self.target = AttitudeTarget((0.0, 0.0, 0.0), ZERO_RATES, 0.0, None)
        self.attitude = (0.0, 0.0, 0.0)     # the target attitude flown now (moves at the rates)
        self.time = 0.0                     # sim s the last target arrived

    def start(self) -> None:
        """angle_control_start: level at the current heading, no rates, climb rate 0."""
        ap = self.ap
        yaw = ap.yaw
        self.active = True
        self.attitude = (0.0, 0.0, yaw)
        self.target = AttitudeTarget(self.attitude, ZERO_RATES, 0.0, None)
        self.time = ap.t
        ap.echo = None

    def stop(self) -> None:
        """Another control takes over (a position target, a takeoff, the mode is left)."""
        self.active = False

    def set(self, tgt: AttitudeTarget) -> None:
        """set_angle: fly `tgt` from now. Body rates alone move the attitude the copter has
        (its target, once flying this way)."""
        ap = self.ap
        if not self.active:
            self.start()
            r, p, _ = ap.euler
            self.attitude = (r, p, self.attitude[2])
        self.target = tgt
        if tgt.attitude is not None:
            self.attitude = tgt.attitude
        self.time = ap.t

    # ----- the tick -----------------------------------------------------------------------
    def timed_out(self) -> bool:
        timeout = max(float(self.ap.params.get("GUID_TIMEOUT", 3.0)), MIN_TIMEOUT_S)
        return self.ap.t - self.time > timeout

    def wants_up(self) -> bool:
        """A positive climb rate or thrust (ArduCopter: takes off, and auto-arms)."""
        tgt = self.target
        return (tgt.thrust if tgt.thrust is not None else tgt.climb) > 0.0

    def update(self, dt: float) -> None:
        """Before the mode runs: the timeout, auto-arming, the target moving at its rates."""
        ap = self.ap
        if self.timed_out():
            self.target = AttitudeTarget(None, ZERO_RATES, 0.0, None)
            self.attitude = (0.0, 0.0, self.attitude[2])
        if ap.armed and self.wants_up():
            ap.auto_armed = True
        self.attitude = _advance(self.attitude, self.target.rates, dt)

    def takes_off(self) -> bool:
        """On the ground, does this control leave it? (auto armed and wanting up)"""
        return self.ap.auto_armed and self.wants_up()

    def fly(self) -> None:
        """The attitude, heading and vertical setpoint of the target."""
        ap = self.ap
        roll, pitch, yaw = self.attitude
        p, q, r = self.target.rates
        sr, cr = math.sin(roll), math.cos(roll)
        yaw_rate = (q * sr + r * cr) / math.cos(pitch)
        ap.hold_yaw = yaw
        ap.echo = None
        tgt = self.target
        ap.setpoint(vel=np.array([0.0, 0.0, -tgt.climb]), roll=roll, pitch=pitch, yaw=yaw,
                    yaw_rate=yaw_rate, rates=(p, q), thrust=tgt.thrust)


def _advance(att: tuple[float, float, float], rates: tuple[float, float, float], dt: float):
    """The attitude `att` (roll, pitch, yaw) turned by body rates (p, q, r) for dt s (Euler
    angle rates of the body rates), roll and pitch kept within MAX_LEAN."""
    p, q, r = rates
    if p == q == r == 0.0:
        return att
    roll, pitch, yaw = att
    sr, cr = math.sin(roll), math.cos(roll)
    cp = math.cos(pitch)
    roll += (p + (q * sr + r * cr) * math.tan(pitch)) * dt
    pitch += (q * cr - r * sr) * dt
    yaw += (q * sr + r * cr) / cp * dt
    return (max(-MAX_LEAN, min(MAX_LEAN, roll)), max(-MAX_LEAN, min(MAX_LEAN, pitch)), wrap_pi(yaw))
