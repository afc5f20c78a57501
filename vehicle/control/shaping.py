"""Jerk-limited kinematic shaping of a position target (ArduPilot's sqrt-controller idea).

The guidance target (position and/or velocity, with optional feed-forward) is not handed
to the vehicle directly: a reference (pos, vel, acc) is moved towards it with speed,
acceleration and jerk limits, and the tracking controller follows the reference with
feed-forward. This is AC_PosControl's shape_pos_vel_accel / shape_vel_accel /
shape_accel chain:

  vel_cmd = sqrt_controller(pos_err, kp, a_dec)  (capped at v_max) + vel_ff
  acc_cmd = sqrt_controller(vel_err, kv, j)      (capped at a_max) + acc_ff
  jerk    = (acc_cmd - acc) / dt                  (capped at j_max)

The sqrt controller is linear (gain k) near zero error and follows the constant-
deceleration curve v = sqrt(2 a e) further out, so the reference arrives without
overshoot. Horizontal shaping acts on the 2-D vector (limits on magnitude), vertical is
1-D with separate up/down speeds, as in ArduPilot.

Component-wise, backend-generic (numpy (n,) arrays or floats; see vehicle.physics).
"""
from __future__ import annotations

from vehicle.physics import NumpyOps
from vehicle.physics.scalar_form import generic

EPS = 1e-9


def sqrt_controller(err, k, lim, dt, xp=NumpyOps):
    """Correction magnitude for a non-negative error magnitude ``err``: k*err near zero,
    sqrt(2 lim (err - lim/2k^2)) beyond lim/k^2, never more than err/dt.
    (Implemented per backend: NumpyOps.sqrt_controller / ScalarOps.sqrt_controller.)"""
    return xp.sqrt_controller(err, k, lim, dt)


_GAINS = {}


def gains(a_max, j_max) -> tuple:
    """(kp position, kv velocity, deceleration used by the position stage). Floats are
    cached; (n,) arrays (a fleet whose vehicles have different limits) are computed."""
    key = (a_max, j_max)
    try:
        out = _GAINS.get(key)
    except TypeError:            # unhashable: per-vehicle (n,) arrays
        return _gains(a_max, j_max)
    if out is None:
        out = _GAINS[key] = _gains(a_max, j_max)
    return out


def _gains(a_max, j_max) -> tuple:
    kv = j_max / a_max
    kp = 0.35 * kv   # tuned: rest-to-rest moves ~0.99x of d/v+v/a+a/j, overshoot < 0.07 m
    a_dec = 0.8 * a_max
    return kp, kv, a_dec


@generic
def shape_xy(r, tpx, tpy, use_pos, tvx, tvy, tax, tay, vmax, amax, jmax, dt, xp=NumpyOps):
    """Advance reference r (attributes px,py,vx,vy,ax,ay) one step towards the target.

    use_pos: bool mask/flag; where False only the velocity target (tv) is followed.
    """
    kp, kv, adec = gains(amax, jmax)
    ex = tpx - r.px
    ey = tpy - r.py
    e = xp.sqrt(ex * ex + ey * ey)
    vm = xp.minimum(xp.sqrt_controller(e, kp, adec, dt), vmax)
    s = xp.where(use_pos, vm / xp.maximum(e, EPS), 0.0)
    vcx = ex * s + tvx
    vcy = ey * s + tvy
    dvx = vcx - r.vx
    dvy = vcy - r.vy
    dv = xp.sqrt(dvx * dvx + dvy * dvy)
    am = xp.minimum(xp.sqrt_controller(dv, kv, jmax, dt), amax)
    s = am / xp.maximum(dv, EPS)
    acx = dvx * s + tax
    acy = dvy * s + tay
    jx = (acx - r.ax) / dt
    jy = (acy - r.ay) / dt
    jm = xp.sqrt(jx * jx + jy * jy)
    s = xp.minimum(1.0, jmax / xp.maximum(jm, EPS)) * dt
    r.ax = r.ax + jx * s
    r.ay = r.ay + jy * s
    vx = r.vx + r.ax * dt
    vy = r.vy + r.ay * dt
    r.px = r.px + 0.5 * (r.vx + vx) * dt
    r.py = r.py + 0.5 * (r.vy + vy) * dt
    r.vx, r.vy = vx, vy


@generic
def shape_z(r, tpz, use_pos, tvz, taz, v_up, v_dn, amax, jmax, dt, xp=NumpyOps):
    """1-D vertical version (NED: negative z is up); attributes pz, vz, az of r."""
    kp, kv, adec = gains(amax, jmax)
    ez = tpz - r.pz
    e = xp.abs(ez)
    vm = xp.sqrt_controller(e, kp, adec, dt)
    vc = xp.where(ez < 0.0, -xp.minimum(vm, v_up), xp.minimum(vm, v_dn))
    vc = xp.where(use_pos, vc, 0.0) + tvz
    dv = vc - r.vz
    am = xp.minimum(xp.sqrt_controller(xp.abs(dv), kv, jmax, dt), amax)
    ac = xp.where(dv < 0.0, -am, am) + taz
    j = xp.clip((ac - r.az) / dt, -jmax, jmax)
    r.az = r.az + j * dt
    vz = r.vz + r.az * dt
    r.pz = r.pz + 0.5 * (r.vz + vz) * dt
    r.vz = vz
