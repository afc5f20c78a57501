"""Skid-steer rover kinematics, batched over vehicles (world NED, body FRD).

Skid-steer (differential drive) was chosen over Ackermann: it can turn in place, so a
rover can stop on a goal and face any heading without orbiting it. Unicycle kinematics:

  speed'  = (speed_cmd - speed) / speed_tau, |speed'| <= max_accel, |speed| <= max_speed
  rate'   = (rate_cmd - rate) / turn_tau,    |rate| <= max_turn_rate
  yaw'    = rate;   x' = speed cos(yaw);   y' = speed sin(yaw);   z = home z

Both lags are discretised exactly (1 - exp(-dt/tau)). No lateral slip.

Wind (vehicle.physics.wind): the tyres take the side force (no lateral slip), so only the
air-relative speed along the heading matters: a drag F = -drag_quad u|u| (u = speed minus
the air velocity along the heading) accelerates the rover by F / mass while its drive is
engaged (speed command not zero); its speed loop holds the command with a small error. A
stopped rover (speed command zero) is braked and does not move. So a rover is pushed far
less than a multicopter, whose whole body floats in the air.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.frames.batch import wrap_pi
from vehicle.physics import NumpyOps
from vehicle.physics.scalar_form import generic


@dataclass
class RoverModel:
    speed_tau: float = 0.25     # s
    turn_tau: float = 0.1       # s
    max_accel: float = 5.0      # m/s^2 physical limit (the controller uses ATC_ACCEL_MAX)
    mass: float = 5.0           # kg (wind push only)
    drag_quad: float = 0.06     # N/(m/s)^2: 0.5 rho Cd A with Cd A about 0.1 m^2


class RoverState:
    FIELDS = ("px", "py", "pz", "vx", "vy", "vz", "qx", "qy", "qz", "qw", "wx", "wy", "wz",
              "ax", "ay", "az", "yaw", "speed", "rate", "ground")
    __slots__ = FIELDS

    def __init__(self, n: int | None, pos=None, yaw=None):
        """n=None builds a scalar (float) state; else arrays of length n."""
        if n is None:
            for f in self.FIELDS:
                setattr(self, f, 0.0)
            if pos is not None:
                self.px, self.py, self.pz = (float(v) for v in pos)
            if yaw is not None:
                self.yaw = float(yaw)
            self.qz, self.qw = math.sin(self.yaw / 2), math.cos(self.yaw / 2)
            self.ground = True
            return
        for f in self.FIELDS:
            setattr(self, f, np.zeros(n))
        if pos is not None:
            pos = np.asarray(pos, float).reshape(n, 3)
            self.px, self.py, self.pz = pos[:, 0].copy(), pos[:, 1].copy(), pos[:, 2].copy()
        if yaw is not None:
            self.yaw = np.broadcast_to(np.asarray(yaw, float), (n,)).copy()
        self.qz, self.qw = np.sin(self.yaw / 2), np.cos(self.yaw / 2)
        self.ground = np.ones(n, dtype=bool)


@generic
def step(s: RoverState, speed_cmd, rate_cmd, m: RoverModel, gains, dt: float, xp=NumpyOps, air=None) -> None:
    """gains supplies max_speed (m/s) and max_rate (rad/s). air: None (still air) or the air
    velocity (north, east, down) m/s, world NED, each component (n,) or float."""
    ks = 1.0 - math.exp(-dt / m.speed_tau)
    kr = 1.0 - math.exp(-dt / m.turn_tau)
    cmd = xp.clip(speed_cmd, -gains.max_speed, gains.max_speed)
    dv = xp.clip((cmd - s.speed) * ks, -m.max_accel * dt, m.max_accel * dt)
    if air is not None:
        u = s.speed - (air[0] * xp.cos(s.yaw) + air[1] * xp.sin(s.yaw))
        dv = dv + xp.where(xp.abs(cmd) > 1e-3, -m.drag_quad * u * xp.abs(u) / m.mass * dt, 0.0)
    s.speed = s.speed + dv
    s.rate = s.rate + (xp.clip(rate_cmd, -gains.max_rate, gains.max_rate) - s.rate) * kr
    s.yaw = wrap_pi(s.yaw + s.rate * dt)
    vx = s.speed * xp.cos(s.yaw)
    vy = s.speed * xp.sin(s.yaw)
    s.ax, s.ay = (vx - s.vx) / dt, (vy - s.vy) / dt
    s.vx, s.vy = vx, vy
    s.px = s.px + vx * dt
    s.py = s.py + vy * dt
    s.qz, s.qw = xp.sin(0.5 * s.yaw), xp.cos(0.5 * s.yaw)
    s.wz = s.rate
