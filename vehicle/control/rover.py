"""Rover guidance + steering/speed control (skid-steer), batched.

  goal (pos, no feed-forward): speed = min(WP_SPEED or CRUISE_SPEED, sqrt(2 decel dist)),
      towards the goal; within WP_RADIUS it stops and latches "reached" (until the goal
      moves or it is pushed 2 WP_RADIUS away), so it never orbits the goal.
  follow (pos + vel feed-forward): velocity = v_ff + ATC_SPEED_P * position error (capped);
      the target position advances by v_ff between updates.
  velocity (vel only): drive at that velocity.   hold (neither): stop.
  heading: turn rate = ATC_STR_ANG_P * heading error (<= ATC_STR_RAT_MAX); speed scaled
      by cos(heading error), zero beyond PIVOT_TURN_ANGLE (turn in place). Stopped with a
      yaw target: turn in place to it; stopped with only a yaw rate: turn at that rate.
  speed command slewed by ATC_ACCEL_MAX / ATC_DECEL_MAX.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from common.frames.batch import wrap_pi, yaw_of
from vehicle.physics import NumpyOps
from vehicle.physics.scalar_form import generic

D2R = math.pi / 180.0


class RoverGains:
    def __init__(self, p: Mapping[str, float], model=None):
        self.cruise = p["WP_SPEED"] if p["WP_SPEED"] > 0 else p["CRUISE_SPEED"]
        self.accel = p["ATC_ACCEL_MAX"] or 3.0
        self.decel = p["ATC_DECEL_MAX"] or self.accel
        self.max_rate = (p["ATC_STR_RAT_MAX"] or 120.0) * D2R
        self.k_hdg = p["ATC_STR_ANG_P"]
        self.k_pos = p["ATC_SPEED_P"]
        self.pivot = p["PIVOT_TURN_ANGLE"] * D2R
        self.radius = p["WP_RADIUS"]
        self.max_speed = p["SIM_RVR_MAX_SPD"]


class RoverSetpointArrays:
    """Per-vehicle targets and guidance memory: (n,) arrays, or floats/bools (n=None);
    v_cmd and r_cmd are the last step's speed (m/s) and turn-rate (rad/s) commands."""

    def __init__(self, n: int | None):
        for f in ("px", "py", "vx", "vy", "yaw", "yaw_rate", "v_cmd", "r_cmd"):
            setattr(self, f, 0.0 if n is None else np.zeros(n))
        for f in ("use_pos", "use_yaw", "use_yaw_rate", "reached"):
            setattr(self, f, False if n is None else np.zeros(n, dtype=bool))


@generic
def step(est, sp: RoverSetpointArrays, g: RoverGains, dt: float, xp=NumpyOps):
    """Returns (speed command m/s, turn-rate command rad/s) arrays."""
    yaw = yaw_of(est.qx, est.qy, est.qz, est.qw, xp.atan2)
    ex = sp.px - est.px
    ey = sp.py - est.py
    dist = xp.sqrt(ex * ex + ey * ey)
    ffm = xp.sqrt(sp.vx * sp.vx + sp.vy * sp.vy)
    has_ff = ffm > 0.05
    goto = sp.use_pos & xp.lnot(has_ff)
    sp.reached = goto & ((dist < g.radius) | (sp.reached & (dist < 2.0 * g.radius)))
    mag_goto = xp.minimum(g.cruise, xp.sqrt(1.2 * g.decel * xp.maximum(dist - 0.5 * g.radius, 0.0)))
    mag_follow = xp.minimum(g.max_speed, g.k_pos * dist)
    mag = xp.where(has_ff, mag_follow, xp.where(sp.reached, 0.0, mag_goto))
    s = xp.where(sp.use_pos, mag / xp.maximum(dist, 1e-9), 0.0)
    # Settle band: a followed target that is close and barely moving (a hovering drone's
    # velocity is mostly estimator noise) is held, not chased, so the rover does not pivot
    # after noise and face a random way when the target sets off again.
    hold = has_ff & (dist < g.radius) & (ffm < 0.3)
    s = xp.where(hold, 0.0, s)
    vx = xp.where(hold, 0.0, sp.vx + ex * s)
    vy = xp.where(hold, 0.0, sp.vy + ey * s)
    spd = xp.minimum(xp.sqrt(vx * vx + vy * vy), g.max_speed)
    moving = spd > 0.05
    hdg = xp.atan2(vy, vx)
    herr = wrap_pi(xp.where(moving, hdg, xp.where(sp.use_yaw, sp.yaw, yaw)) - yaw)
    rate = xp.clip(g.k_hdg * herr, -g.max_rate, g.max_rate)
    # stopped with only a yaw rate commanded: turn in place at that rate
    rate = xp.where(sp.use_yaw_rate & xp.lnot(sp.use_yaw | moving),
                    xp.clip(sp.yaw_rate, -g.max_rate, g.max_rate), rate)
    v = xp.where(xp.abs(herr) > g.pivot, 0.0, spd * xp.maximum(xp.cos(herr), 0.0))
    v = xp.clip(v, sp.v_cmd - g.decel * dt, sp.v_cmd + g.accel * dt)
    sp.v_cmd = v
    sp.r_cmd = rate
    # A followed target moves on between updates: advance it by its velocity, as
    # AC_PosControl advances a position+velocity target, so a 10 Hz stream of goals
    # reads as a moving point rather than a staircase the rover lags behind.
    lead = xp.where(sp.use_pos & has_ff, dt, 0.0)
    sp.px = sp.px + sp.vx * lead
    sp.py = sp.py + sp.vy * lead
    return v, rate
