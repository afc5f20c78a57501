"""Copter position + attitude cascade (ArduPilot AC_PosControl / AC_AttitudeControl shape).

  guidance target --shaping--> reference (pos, vel, acc; jerk/accel/speed limited)
  position P (PSC_POSXY_P, PSC_POSZ_P)             -> velocity target (+ reference vel)
  velocity PID (PSC_VELXY_*, PSC_VELZ_*)           -> acceleration (+ reference acc)
  acceleration -> lean angles in the yaw frame (limited by ANGLE_MAX) + collective thrust
  attitude P on the quaternion error (ATC_ANG_*)   -> body-rate target
  rate PID (ATC_RAT_*) on normalised torque        -> quad-X mixer
  mixer: roll/pitch fitted first (throttle shifted to make room), yaw gets what headroom
  is left, motors clipped to [spin_min, 1]; thrust is linearised (rotor speed = sqrt).

Backend-generic and component-wise (numpy (n,) arrays or floats, see vehicle.physics).
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from common.frames.batch import wrap_pi, yaw_of
from vehicle.control import shaping
from vehicle.physics import NumpyOps
from vehicle.physics.multicopter import GRAVITY
from vehicle.physics.scalar_form import generic

D2R = math.pi / 180.0


class CopterGains:
    """SI gains and limits from an ArduPilot-named parameter mapping."""

    def __init__(self, p: Mapping[str, float]):
        self.v_xy = p["WPNAV_SPEED"] / 100.0
        self.v_up = p["WPNAV_SPEED_UP"] / 100.0
        self.v_dn = p["WPNAV_SPEED_DN"] / 100.0
        self.a_xy = p["WPNAV_ACCEL"] / 100.0
        self.a_z = p["WPNAV_ACCEL_Z"] / 100.0
        self.j_xy = p["PSC_JERK_XY"]
        self.j_z = p["PSC_JERK_Z"]
        self.angle_max = p["ANGLE_MAX"] / 100.0 * D2R
        self.tan_angle_max = math.tan(self.angle_max)
        self.land_speed = p["LAND_SPEED"] / 100.0
        self.kp_xy = p["PSC_POSXY_P"]
        self.kv_xy = p["PSC_VELXY_P"]
        self.ki_xy = p["PSC_VELXY_I"]
        self.kd_xy = p["PSC_VELXY_D"]
        self.imax_xy = p["PSC_VELXY_IMAX"] / 100.0
        self.kp_z = p["PSC_POSZ_P"]
        self.kv_z = p["PSC_VELZ_P"]
        self.ki_z = p["PSC_VELZ_I"]
        self.imax_z = p["PSC_VELZ_IMAX"] / 100.0
        self.ang_r, self.ang_p, self.ang_y = p["ATC_ANG_RLL_P"], p["ATC_ANG_PIT_P"], p["ATC_ANG_YAW_P"]
        self.rat = [(p[f"ATC_RAT_{a}_P"], p[f"ATC_RAT_{a}_I"], p[f"ATC_RAT_{a}_D"], p[f"ATC_RAT_{a}_IMAX"])
                    for a in ("RLL", "PIT", "YAW")]
        self.rate_y_max = (p["ATC_RATE_Y_MAX"] or 90.0) * D2R
        self.rate_rp_max = (p["ATC_RATE_RP_MAX"] or 360.0) * D2R
        self.hover = p["MOT_THST_HOVER"]
        self.spin_arm = p["MOT_SPIN_ARM"]
        self.spin_min = p["MOT_SPIN_MIN"]
        self.land_time = p["LAND_DETECT_TIME"]


class SetpointArrays:
    """Per-vehicle guidance targets, component-wise. use_pos_xy/use_pos_z select position
    control per axis group; velocity and acceleration are targets (pos unused) or
    feed-forward (pos used). level=True: STABILIZE-like, roll/pitch held level (no
    horizontal control), altitude and yaw held.

    att=True: an attitude target (ArduCopter GUIDED's angle control): no horizontal control;
    the copter leans to roll/pitch given as tan_roll/tan_pitch (ZYX Euler in the yaw frame)
    at heading yaw (yaw_rate its feed-forward), wx/wy are body roll/pitch rate feed-forward
    (rad/s), the vertical loop flies the velocity target vz (climb rate), or with use_thrust
    `thrust` (0..1) is the collective, boosted for the tilt as ArduPilot's angle boost."""

    __slots__ = ("px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "yaw", "yaw_rate",
                 "tan_roll", "tan_pitch", "wx", "wy", "thrust",
                 "use_pos_xy", "use_pos_z", "use_yaw", "level", "att", "use_thrust")

    def __init__(self, n: int | None):
        z = (lambda: 0.0) if n is None else (lambda: np.zeros(n))
        b = (lambda v: v) if n is None else (lambda v: np.full(n, v, dtype=bool))
        for f in ("px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "yaw", "yaw_rate",
                  "tan_roll", "tan_pitch", "wx", "wy", "thrust"):
            setattr(self, f, z())
        self.use_pos_xy = b(False)
        self.use_pos_z = b(False)
        self.use_yaw = b(False)
        self.level = b(False)
        self.att = b(False)
        self.use_thrust = b(False)


class CopterCtrlState:
    """Controller memory: shaped reference, yaw reference, integrators, D filters; and what
    the last step asked for, for telemetry: the attitude target (tan_roll_t, tan_pitch_t),
    the body-rate target (rtx, rty, rtz, rad/s FRD) and the vertical acceleration target
    (atz, m/s^2 NED, down positive); att_err, sin^2 of half the angle between the target and
    the estimated thrust axes (ArduPilot's thrust error angle, read by the land detector and
    the crash check); lax, lay, laz: the land detector's 1 Hz low-passed acceleration (world
    NED m/s^2, vehicle.fleet._land_detect keeps it); f0..f3: the mixer's four rotor-speed
    commands (0..1, ArduPilot's motor order; the thrust loss check's)."""
    FIELDS = ("px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "yaw",
              "ivx", "ivy", "ivz", "evx", "evy", "dvx", "dvy",
              "irx", "iry", "irz", "erx", "ery", "erz", "drx", "dry", "drz", "coll",
              "tan_roll_t", "tan_pitch_t", "rtx", "rty", "rtz", "atz", "att_err", "lax", "lay", "laz",
              "f0", "f1", "f2", "f3")
    __slots__ = FIELDS + ("yaw_seen", "yaw_half")

    def __init__(self, n: int | None):
        for f in self.FIELDS:
            setattr(self, f, 0.0 if n is None else np.zeros(n))
        self.yaw_seen = None          # the yaw that yaw_half = (cos, sin) of yaw/2 belong to
        self.yaw_half = None


@generic
def _half_yaw(c: CopterCtrlState, xp):
    """(cos, sin) of c.yaw / 2, kept while the yaw reference does not change: a held
    heading is the common case, and a sin/cos pair is the dearest thing in the step."""
    yaw = c.yaw
    seen = c.yaw_seen
    if seen is None or not xp.all(yaw == seen):
        hy = 0.5 * yaw
        c.yaw_half = (xp.cos(hy), xp.sin(hy))
        c.yaw_seen = yaw + 0.0          # a copy: an in-place write to c.yaw must not hide
    return c.yaw_half


@generic
def relax(c: CopterCtrlState, est, mask, xp=NumpyOps) -> None:
    """Where mask: reset the reference to the estimate at rest and clear integrators
    (ArduPilot relaxes its controllers while landed)."""
    c.px, c.py, c.pz = xp.where(mask, est.px, c.px), xp.where(mask, est.py, c.py), xp.where(mask, est.pz, c.pz)
    for f in ("vx", "vy", "vz", "ax", "ay", "az", "ivx", "ivy", "ivz", "evx", "evy", "dvx", "dvy",
              "irx", "iry", "irz", "erx", "ery", "erz", "drx", "dry", "drz"):
        setattr(c, f, xp.where(mask, 0.0, getattr(c, f)))
    c.yaw = xp.where(mask, yaw_of(est.qx, est.qy, est.qz, est.qw, xp.atan2), c.yaw)


_ALPHA = {}


def _filter_alphas(dt: float) -> tuple[float, float]:
    a = _ALPHA.get(dt)
    if a is None:
        a = _ALPHA[dt] = (1.0 - math.exp(-2.0 * math.pi * 5.0 * dt), 1.0 - math.exp(-2.0 * math.pi * 20.0 * dt))
    return a


@generic
def step(c: CopterCtrlState, est, sp: SetpointArrays, g: CopterGains, dt: float, xp=NumpyOps):
    """One controller step on the estimate ``est`` (attributes px..vz, qx..qw, wx..wz).

    Returns the four rotor-speed fractions (0..1; multiply by omega_max) and stores the
    collective thrust fraction in c.coll."""
    level = sp.level
    att = sp.att
    any_att = xp.any(att)
    if any_att:
        level = level | att       # an attitude target has no horizontal control either
    # ---- shaping of the reference ------------------------------------------------
    shaping.shape_xy(c, sp.px, sp.py, sp.use_pos_xy, sp.vx, sp.vy, sp.ax, sp.ay,
                     g.v_xy, g.a_xy, g.j_xy, dt, xp)
    shaping.shape_z(c, sp.pz, sp.use_pos_z, sp.vz, sp.az, g.v_up, g.v_dn, g.a_z, g.j_z, dt, xp)
    any_level = xp.any(level)
    if any_level:
        # level mode: no horizontal control; the reference rides on the estimate
        c.px, c.py = xp.where(level, est.px, c.px), xp.where(level, est.py, c.py)
        c.vx, c.vy = xp.where(level, est.vx, c.vx), xp.where(level, est.vy, c.vy)
        c.ax, c.ay = xp.where(level, 0.0, c.ax), xp.where(level, 0.0, c.ay)
    # yaw reference: slew to the target yaw, or integrate a yaw rate
    ymax = g.rate_y_max
    if xp.any(sp.use_yaw):
        dy = wrap_pi(sp.yaw - c.yaw)
        # an attitude target's heading moves at its yaw rate: the reference's feed-forward
        ff = xp.where(att, sp.yaw_rate, 0.0) if any_att else 0.0
        yr = xp.where(sp.use_yaw, xp.clip(dy * g.ang_y + ff, -ymax, ymax), xp.clip(sp.yaw_rate, -ymax, ymax))
    else:                     # no yaw targets: the wrap (np.remainder, dear) is not needed
        yr = xp.clip(sp.yaw_rate, -ymax, ymax)
    c.yaw = wrap_pi(c.yaw + yr * dt)

    # ---- position / velocity -----------------------------------------------------
    vtx = c.vx + g.kp_xy * (c.px - est.px)
    vty = c.vy + g.kp_xy * (c.py - est.py)
    evx = vtx - est.vx
    evy = vty - est.vy
    c.ivx = xp.clip(c.ivx + g.ki_xy * evx * dt, -g.imax_xy, g.imax_xy)
    c.ivy = xp.clip(c.ivy + g.ki_xy * evy * dt, -g.imax_xy, g.imax_xy)
    alpha, alpha_r = _filter_alphas(dt)                       # 5 Hz / 20 Hz D filters
    c.dvx = c.dvx + ((evx - c.evx) / dt - c.dvx) * alpha
    c.dvy = c.dvy + ((evy - c.evy) / dt - c.dvy) * alpha
    c.evx, c.evy = evx, evy
    atx = c.ax + g.kv_xy * evx + c.ivx + g.kd_xy * c.dvx
    aty = c.ay + g.kv_xy * evy + c.ivy + g.kd_xy * c.dvy
    if any_level:
        atx = xp.where(level, 0.0, atx)
        aty = xp.where(level, 0.0, aty)
        c.ivx, c.ivy = xp.where(level, 0.0, c.ivx), xp.where(level, 0.0, c.ivy)

    vtz = c.vz + g.kp_z * (c.pz - est.pz)
    evz = vtz - est.vz
    c.ivz = xp.clip(c.ivz + g.ki_z * evz * dt, -g.imax_z, g.imax_z)
    atz = c.az + g.kv_z * evz + c.ivz
    up_max = GRAVITY * (0.9 / g.hover - 1.0)
    atz = xp.clip(atz, -up_max, 0.8 * GRAVITY)
    g_eff = GRAVITY - atz

    # horizontal acceleration limited by the lean-angle limit
    ah = xp.sqrt(atx * atx + aty * aty)
    ah_max = g_eff * g.tan_angle_max
    s = xp.minimum(1.0, ah_max / xp.maximum(ah, 1e-9))
    atx, aty = atx * s, aty * s

    # ---- thrust vector + yaw -> attitude target -----------------------------------
    qx, qy, qz, qw = est.qx, est.qy, est.qz, est.qw
    # target attitude from yaw and the lean angles pitch = atan(-a_f / g_eff),
    # roll = atan(a_r cos(pitch) / g_eff), as half-angle cosines/sines. One sin/cos pair
    # (of yaw/2) and square roots instead of nine trig calls and two atans: the same
    # numbers to rounding, and trig is ~50x dearer than a multiply on numpy arrays.
    cyy, syy = _half_yaw(c, xp)
    cy, sy = cyy * cyy - syy * syy, 2.0 * cyy * syy   # cos, sin of the target yaw
    a_f = atx * cy + aty * sy                 # lean angles in the target-yaw frame
    a_r = -atx * sy + aty * cy
    tp = -a_f / g_eff                         # tan(pitch); g_eff >= 0.2 g, |pitch| < pi/2
    if any_att:
        tp = xp.where(att, sp.tan_pitch, tp)  # an attitude target's own lean angles
    cpf = 1.0 / xp.sqrt(1.0 + tp * tp)        # cos(pitch)
    cp, spp = _half_angle(cpf, tp * cpf, xp)
    tr = a_r * cpf / g_eff                    # tan(roll)
    if any_att:
        tr = xp.where(att, sp.tan_roll, tr)
    crf = 1.0 / xp.sqrt(1.0 + tr * tr)
    cr, sr = _half_angle(crf, tr * crf, xp)
    dw = cr * cp * cyy + sr * spp * syy
    dx = sr * cp * cyy - cr * spp * syy
    dyq = cr * spp * cyy + sr * cp * syy
    dz = cr * cp * syy - sr * spp * cyy
    # error quaternion conj(q) (x) q_des
    ew = qw * dw + qx * dx + qy * dyq + qz * dz
    ex = qw * dx - qx * dw - qy * dz + qz * dyq
    ey = qw * dyq + qx * dz - qy * dw - qz * dx
    ez = qw * dz - qx * dyq + qy * dx - qz * dw
    sgn = xp.where(ew < 0.0, -2.0, 2.0)
    rpm = g.rate_rp_max
    rtx = xp.clip(g.ang_r * sgn * ex, -rpm, rpm)
    rty = xp.clip(g.ang_p * sgn * ey, -rpm, rpm)
    rtz = xp.clip(g.ang_y * sgn * ez, -ymax, ymax) + yr
    if any_att:
        rtx, rty = rtx + sp.wx, rty + sp.wy   # body-rate feed-forward (0 where no attitude target)

    # ---- rate PID -----------------------------------------------------------------
    (pr, ir, dr, mr), (pp, ip, dp, mp), (py, iy, dyy, my) = g.rat
    erx = rtx - est.wx
    ery = rty - est.wy
    erz = rtz - est.wz
    c.irx = xp.clip(c.irx + ir * erx * dt, -mr, mr)
    c.iry = xp.clip(c.iry + ip * ery * dt, -mp, mp)
    c.irz = xp.clip(c.irz + iy * erz * dt, -my, my)
    c.drx = c.drx + ((erx - c.erx) / dt - c.drx) * alpha_r
    c.dry = c.dry + ((ery - c.ery) / dt - c.dry) * alpha_r
    c.drz = c.drz + ((erz - c.erz) / dt - c.drz) * alpha_r
    c.erx, c.ery, c.erz = erx, ery, erz
    u_r = pr * erx + c.irx + dr * c.drx
    u_p = pp * ery + c.iry + dp * c.dry
    u_y = py * erz + c.irz + dyy * c.drz

    # ---- collective: required specific force projected on the current thrust axis --
    r13 = 2.0 * (qx * qz + qw * qy)
    r23 = 2.0 * (qy * qz - qw * qx)
    r33 = 1.0 - 2.0 * (qx * qx + qy * qy)
    f_proj = -(atx * r13 + aty * r23 + (atz - GRAVITY) * r33)
    coll = xp.clip(g.hover * f_proj / GRAVITY, 0.0, 1.0)
    if any_att:
        coll = _attitude_collective(c, est, sp, g, g_eff, r33, coll, xp)
    c.coll = coll
    c.tan_roll_t, c.tan_pitch_t = tr, tp      # the attitude target (NAV_CONTROLLER_OUTPUT)
    c.rtx, c.rty, c.rtz, c.atz = rtx, rty, rtz, atz    # rate and climb targets (PID_TUNING)
    c.att_err = ex * ex + ey * ey             # the error rotation's R33 is 1 - 2 att_err
    out = mix(coll, u_r, u_p, u_y, g.spin_min, xp)
    c.f0, c.f1, c.f2, c.f3 = out
    return out


@generic
def _attitude_collective(c, est, sp, g, g_eff, r33, coll, xp=NumpyOps):
    """The collective where an attitude target flies (elsewhere `coll` as it was): the
    vertical loop's force over the current tilt, or the target's thrust, both boosted by
    1/cos(tilt) (faded out past 84 deg, as ArduPilot's angle boost). In thrust lanes the
    vertical loop rides on the estimate, so climb-rate control resumes without a jump."""
    boost = xp.clip(10.0 * r33, 0.0, 1.0) / xp.maximum(r33, 0.1)
    ut = sp.use_thrust
    c.pz, c.vz = xp.where(ut, est.pz, c.pz), xp.where(ut, est.vz, c.vz)
    c.az, c.ivz = xp.where(ut, 0.0, c.az), xp.where(ut, 0.0, c.ivz)
    want = xp.where(ut, sp.thrust, g.hover * g_eff / GRAVITY) * boost
    return xp.where(sp.att, xp.clip(want, 0.0, 1.0), coll)


@generic
def _half_angle(c, s, xp=NumpyOps):
    """(cos, sin) of theta/2 from (cos, sin) of theta, for |theta| < pi/2 (c > 0, so
    cos(theta/2) >= 0.707 and neither formula cancels)."""
    ch = xp.sqrt(0.5 * (1.0 + c))
    return ch, s / (2.0 * ch)


@generic
def mix(coll, u_r, u_p, u_y, spin_min, xp=NumpyOps):
    """Quad-X mixer with saturation handling; returns 4 rotor-speed fractions."""
    hr, hp = 0.5 * u_r, 0.5 * u_p
    rp0 = hp - hr                    # front-right; back-left is -rp0 (exactly, in floats)
    rp2 = hr + hp                    # front-left; back-right is -rp2
    mx = 0.5 * (xp.abs(u_r) + xp.abs(u_p))     # largest motor offset; the smallest is -mx
    fmin = spin_min * spin_min
    span_max = 1.0 - fmin
    sc = xp.minimum(1.0, span_max / xp.maximum(2.0 * mx, 1e-9))
    rp0, rp2, mx = rp0 * sc, rp2 * sc, mx * sc
    thr = xp.clip(coll, fmin + mx, 1.0 - mx)
    # yaw: motors 0,1 get +y/2, motors 2,3 get -y/2; use only remaining headroom
    # (rp1 = -rp0 and rp3 = -rp2, so each pair's extreme is thr +- |rp|)
    a0, a1, a2, a3 = thr + rp0, thr - rp0, thr + rp2, thr - rp2
    m01 = xp.abs(rp0)
    m23 = xp.abs(rp2)
    hi = 2.0 * xp.minimum(1.0 - thr - m01, thr - m23 - fmin)
    lo = -2.0 * xp.minimum(thr - m01 - fmin, 1.0 - thr - m23)
    yaw = xp.clip(u_y, xp.minimum(lo, 0.0), xp.maximum(hi, 0.0))
    hy = 0.5 * yaw
    f0 = xp.clip(a0 + hy, fmin, 1.0)
    f1 = xp.clip(a1 + hy, fmin, 1.0)
    f2 = xp.clip(a2 - hy, fmin, 1.0)
    f3 = xp.clip(a3 - hy, fmin, 1.0)
    return xp.sqrt(f0), xp.sqrt(f1), xp.sqrt(f2), xp.sqrt(f3)
