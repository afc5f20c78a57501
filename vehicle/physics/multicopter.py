"""Quad-X multicopter: 6-DOF rigid body in world NED, body FRD, batched over vehicles.

State is stored component-wise (see vehicle.physics): each attribute is an (n,) array or
a float. Quaternions are (x, y, z, w), body -> world, as in scipy/ROS.

Model
- 4 rotors, ArduPilot quad-X order: 0 front-right (CCW), 1 back-left (CCW),
  2 front-left (CW), 3 back-right (CW). Thrust T = kT w^2 along body -z, reaction
  torque +-kQ/kT * T about body z (CCW rotors push the body's yaw positive).
- Rotor speed follows its command with a first-order lag (time constant motor_tau),
  discretised exactly: w += (w_cmd - w) (1 - exp(-dt/tau)).
- Drag: F = -(c_lin + c_quad |v_a|) v_a on the air-relative velocity v_a = v - air (world
  frame, isotropic); air is the wind's air velocity (vehicle.physics.wind), zero on the
  ground, where ground contact holds the vehicle. A hovering quad in wind therefore needs a
  steady horizontal force: its position controller's integrator leans it into the wind.
  Angular damping.
- Gravity +g along NED z.
- Ground: z >= ground_z is the ground (NED z = 0 at home ground). When the net force
  presses the vehicle into the ground it sits on it: z clamped, no downward speed,
  horizontal speed decays with friction, roll/pitch levelled, rates damped. One that comes
  down leaning more than TIP_OVER_DEG has crashed: it lies as it fell, not levelled
  (ArduPilot's SITL levels every vehicle on the ground; here a wreck keeps the lean that
  ArduCopter's crash check looks for).
- Integration: semi-implicit (symplectic) Euler at a fixed step; the quaternion is
  advanced by the body-rate increment and renormalised every step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.frames.batch import yaw_of
from vehicle.physics import NumpyOps
from vehicle.physics.scalar_form import generic

GRAVITY = 9.80665

# per-motor geometry factors (quad X, ArduPilot order FR, BL, FL, BR)
MOTOR_X = (1.0, -1.0, 1.0, -1.0)     # times arm/sqrt(2): forward
MOTOR_Y = (1.0, -1.0, -1.0, 1.0)     # right
MOTOR_SPIN = (1.0, 1.0, -1.0, -1.0)  # +1 CCW rotor -> positive yaw reaction torque
TIP_OVER_DEG = 60.0     # on the ground leaning more than this it has tipped over (not levelled)
# qx^2 + qy^2 of that lean: cos(lean) = 1 - 2 (qx^2 + qy^2)
_TIP_OVER_XY2 = 0.5 * (1.0 - math.cos(math.radians(TIP_OVER_DEG)))


@dataclass(frozen=True)
class QuadAirframe:
    """A 1.8 kg, 500 mm class quad. hover_throttle sets the maximum thrust. Immutable
    (derived constants are cached); build a new one with dataclasses.replace."""
    mass: float = 1.8            # kg
    arm: float = 0.25            # m, centre to motor
    ixx: float = 0.021           # kg m^2
    iyy: float = 0.021
    izz: float = 0.037
    hover_throttle: float = 0.45  # thrust fraction of full thrust that hovers
    omega_max: float = 1100.0    # rad/s rotor speed at full command
    motor_tau: float = 0.025     # s
    yaw_coeff: float = 0.016     # m: reaction torque / thrust
    drag_lin: float = 0.04       # N/(m/s)
    drag_quad: float = 0.03      # N/(m/s)^2
    ang_damp: float = 0.003      # N m/(rad/s)
    ground_friction: float = 12.0  # 1/s decay of horizontal speed on the ground

    def __post_init__(self):
        object.__setattr__(self, "_kt", self.kt)
        object.__setattr__(self, "_arm_xy", self.arm_xy)

    @property
    def max_thrust(self) -> float:
        """Full thrust of one motor, N."""
        return self.mass * GRAVITY / (4.0 * self.hover_throttle)

    @property
    def kt(self) -> float:
        return self.max_thrust / self.omega_max ** 2

    @property
    def arm_xy(self) -> float:
        return self.arm / math.sqrt(2.0)


class QuadState:
    """Component-wise state of n quads (arrays of shape (n,)) or of one (floats)."""
    FIELDS = ("px", "py", "pz", "vx", "vy", "vz", "qx", "qy", "qz", "qw",
              "wx", "wy", "wz", "m0", "m1", "m2", "m3", "ax", "ay", "az", "ground")
    __slots__ = FIELDS

    def __init__(self, n: int | None = None, pos=None, yaw=None):
        """n=None builds a scalar (float) state; else arrays of length n."""
        if n is None:
            for f in self.FIELDS:
                setattr(self, f, 0.0)
            self.qw = 1.0
            self.ground = True
            if pos is not None:
                self.px, self.py, self.pz = (float(v) for v in pos)
            if yaw is not None:
                self.qz, self.qw = math.sin(yaw / 2), math.cos(yaw / 2)
            return
        for f in self.FIELDS:
            setattr(self, f, np.zeros(n))
        self.qw = np.ones(n)
        self.ground = np.ones(n, dtype=bool)
        if pos is not None:
            pos = np.asarray(pos, float).reshape(n, 3)
            self.px, self.py, self.pz = pos[:, 0].copy(), pos[:, 1].copy(), pos[:, 2].copy()
        if yaw is not None:
            yaw = np.broadcast_to(np.asarray(yaw, float), (n,))
            self.qz, self.qw = np.sin(yaw / 2), np.cos(yaw / 2)


@generic
def step(s: QuadState, cmd, af: QuadAirframe, dt: float, ground_z, xp=NumpyOps, air=None) -> None:
    """Advance the state by dt. cmd = 4 rotor-speed commands (rad/s), each (n,) or float.
    air: None (still air) or the air velocity (north, east, down) m/s, world NED, each
    component (n,) or float; ignored where the vehicle was on the ground."""
    k = 1.0 - math.exp(-dt / af.motor_tau)
    m0 = s.m0 + (cmd[0] - s.m0) * k
    m1 = s.m1 + (cmd[1] - s.m1) * k
    m2 = s.m2 + (cmd[2] - s.m2) * k
    m3 = s.m3 + (cmd[3] - s.m3) * k
    s.m0, s.m1, s.m2, s.m3 = m0, m1, m2, m3
    kt = af._kt
    t0, t1, t2, t3 = kt * m0 * m0, kt * m1 * m1, kt * m2 * m2, kt * m3 * m3
    thrust = t0 + t1 + t2 + t3
    d = af._arm_xy
    tau_x = d * (-t0 + t1 + t2 - t3)           # -y_i T_i
    tau_y = d * (t0 - t1 + t2 - t3)            # +x_i T_i
    tau_z = af.yaw_coeff * (t0 + t1 - t2 - t3)

    qx, qy, qz, qw = s.qx, s.qy, s.qz, s.qw
    # third column of R (body z axis in world)
    r13 = 2.0 * (qx * qz + qw * qy)
    r23 = 2.0 * (qy * qz - qw * qx)
    r33 = 1.0 - 2.0 * (qx * qx + qy * qy)
    vx, vy, vz = s.vx, s.vy, s.vz
    if air is None:
        rx, ry, rz = vx, vy, vz
    else:
        fly = xp.lnot(s.ground)          # on the ground its contact holds it (friction)
        rx = vx - xp.where(fly, air[0], 0.0)
        ry = vy - xp.where(fly, air[1], 0.0)
        rz = vz - xp.where(fly, air[2], 0.0)
    speed = xp.sqrt(rx * rx + ry * ry + rz * rz)
    cd = af.drag_lin + af.drag_quad * speed
    inv_m = 1.0 / af.mass
    ax = (-thrust * r13 - cd * rx) * inv_m
    ay = (-thrust * r23 - cd * ry) * inv_m
    az = (-thrust * r33 - cd * rz) * inv_m + GRAVITY

    # rotational dynamics: I w' = tau - w x (I w) - c w
    wx, wy, wz = s.wx, s.wy, s.wz
    ixx, iyy, izz, c = af.ixx, af.iyy, af.izz, af.ang_damp
    wx_n = wx + dt * (tau_x - (izz - iyy) * wy * wz - c * wx) / ixx
    wy_n = wy + dt * (tau_y - (ixx - izz) * wz * wx - c * wy) / iyy
    wz_n = wz + dt * (tau_z - (iyy - ixx) * wx * wy - c * wz) / izz

    # translational: semi-implicit Euler
    vx_n = vx + ax * dt
    vy_n = vy + ay * dt
    vz_n = vz + az * dt
    px_n = s.px + vx_n * dt
    py_n = s.py + vy_n * dt
    pz_n = s.pz + vz_n * dt

    # attitude: q <- q (x) exp(w dt / 2) (Taylor to 3rd order in the half angle), renormalised
    hx, hy, hz = 0.5 * dt * wx_n, 0.5 * dt * wy_n, 0.5 * dt * wz_n
    hh = hx * hx + hy * hy + hz * hz
    cw = 1.0 - 0.5 * hh
    sv = 1.0 - hh / 6.0
    hx, hy, hz = hx * sv, hy * sv, hz * sv
    nw = qw * cw - qx * hx - qy * hy - qz * hz
    nx = qx * cw + qw * hx + qy * hz - qz * hy
    ny = qy * cw + qw * hy - qx * hz + qz * hx
    nz = qz * cw + qw * hz + qx * hy - qy * hx
    inv = 1.0 / xp.sqrt(nx * nx + ny * ny + nz * nz + nw * nw)
    nx, ny, nz, nw = nx * inv, ny * inv, nz * inv, nw * inv

    # ground contact: pressed into the ground (at or below it and net force down)
    g = (pz_n >= ground_z) & (az >= 0.0)
    below = pz_n > ground_z
    if xp.any(g | below):
        pz_n = xp.where(below | g, xp.minimum(pz_n, ground_z), pz_n)
        vz_n = xp.where(g | (below & (vz_n > 0.0)), xp.minimum(vz_n, 0.0), vz_n)
        fr = math.exp(-af.ground_friction * dt)
        vx_n = xp.where(g, vx_n * fr, vx_n)
        vy_n = xp.where(g, vy_n * fr, vy_n)
        # level roll/pitch on the ground, keep yaw; tipped over past TIP_OVER_DEG it lies
        # as it fell (a crash: the attitude it had stays, whatever the motors do)
        tip = g & (nx * nx + ny * ny > _TIP_OVER_XY2)
        lv = g
        if xp.any(tip):                  # (rare: most steps on the ground are level)
            nx, ny = xp.where(tip, s.qx, nx), xp.where(tip, s.qy, ny)
            nz, nw = xp.where(tip, s.qz, nz), xp.where(tip, s.qw, nw)
            lv = g & xp.lnot(tip)
        yaw = yaw_of(nx, ny, nz, nw, xp.atan2)
        nx = xp.where(lv, 0.0, nx)
        ny = xp.where(lv, 0.0, ny)
        nz = xp.where(lv, xp.sin(0.5 * yaw), nz)
        nw = xp.where(lv, xp.cos(0.5 * yaw), nw)
        wx_n = xp.where(g, 0.0, wx_n)
        wy_n = xp.where(g, 0.0, wy_n)
        wz_n = xp.where(g, wz_n * fr, wz_n)
        ax = xp.where(g, 0.0, ax)
        ay = xp.where(g, 0.0, ay)
        az = xp.where(g, 0.0, az)
    s.ax, s.ay, s.az = ax, ay, az
    s.px, s.py, s.pz = px_n, py_n, pz_n
    s.vx, s.vy, s.vz = vx_n, vy_n, vz_n
    s.qx, s.qy, s.qz, s.qw = nx, ny, nz, nw
    s.wx, s.wy, s.wz = wx_n, wy_n, wz_n
    s.ground = g


def rotor_power(s: QuadState, af: QuadAirframe, rho: float = 1.225, disk_area: float = 0.05,
                figure_of_merit: float = 0.6):
    """Shaft power (W) the four rotors absorb, from momentum theory: each rotor's ideal
    induced power T^1.5 / sqrt(2 rho A) divided by a figure of merit (profile losses).
    disk_area m^2 per rotor (0.05: 10-inch propellers). Float or (n,) like the state."""
    kt = af._kt
    t = [kt * m * m for m in (s.m0, s.m1, s.m2, s.m3)]
    k = 1.0 / (math.sqrt(2.0 * rho * disk_area) * figure_of_merit)
    return k * sum(np.abs(ti) ** 1.5 for ti in t)


def hover_omega(af: QuadAirframe) -> float:
    """Rotor speed that hovers (all four equal)."""
    return af.omega_max * math.sqrt(af.hover_throttle)
