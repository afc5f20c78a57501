"""The scalar forms of the cores (vehicle.physics.scalar_form) compute what the cores compute
on ScalarOps, bit for bit: each inlined rule on special values, then every core on random
states."""
from __future__ import annotations

import copy
import itertools
import math
import struct

import numpy as np

from vehicle.control import copter as ccore
from vehicle.control import rover as rcore
from vehicle.control import shaping
from vehicle.fleet import CopterFleet, RoverFleet, Setpoint
from vehicle.physics import NumpyOps, ScalarOps
from vehicle.physics import multicopter as mc
from vehicle.physics import rover as rphys
from vehicle.physics.scalar_form import generic

SPECIAL = (math.nan, -math.inf, -2.5, -1.0, -0.0, 0.0, 1e-300, 1.0, 2.5, math.inf)


def _bits(v):
    """A value as bits (floats: their IEEE pattern, so -0.0 != 0.0 and NaN == NaN)."""
    if isinstance(v, float):
        return struct.pack("<d", v)
    if isinstance(v, (tuple, list)):
        return type(v)(_bits(x) for x in v)
    return v


@generic
def _rules(a, b, c, xp=NumpyOps):
    return (xp.where(a < b, a, c), xp.clip(a, b, c), xp.clip(a * 2.0, -b, c + 1.0), xp.minimum(a, b),
            xp.maximum(a, b), xp.minimum(a + b, c), xp.maximum(c, a - b), xp.lnot(a > b), xp.any(a > c),
            xp.all(b), xp.abs(a), xp.sqrt_controller(xp.abs(a), 2.0, 3.0, 0.01), xp.atan2(a, b))


def test_each_rule_matches_scalar_ops_on_special_values():
    form = _rules.scalar()
    assert form is not _rules.__wrapped__
    for a, b, c in itertools.product(SPECIAL, repeat=3):
        try:
            want = _rules.__wrapped__(a, b, c, ScalarOps)
        except (ValueError, OverflowError):     # math.sqrt of a negative, inf arithmetic
            continue
        assert _bits(form(a, b, c, ScalarOps)) == _bits(want), (a, b, c)


def test_dispatch_by_backend():
    assert _bits(_rules(1.0, 2.0, 3.0, xp=ScalarOps)) == _bits(_rules.__wrapped__(1.0, 2.0, 3.0, ScalarOps))
    out = _rules(np.array([1.0, 5.0]), np.array([2.0, 2.0]), np.array([3.0, 0.5]))
    assert isinstance(out[0], np.ndarray) and out[1].tolist() == [2.0, 0.5]


def _airborne(kind, seed):
    """A scalar fleet of one, flown a while from a random start, with its state objects."""
    rng = np.random.default_rng(seed)
    if kind == "copter":
        f = CopterFleet(1, seed=seed, yaw=float(rng.uniform(-3, 3)))
    else:
        f = RoverFleet(1, seed=seed, yaw=float(rng.uniform(-3, 3)))
    f.set_armed(0, True)
    f.set_setpoint(0, Setpoint(pos=rng.uniform(-20, 20, 3) * [1, 1, 0.4] - [0, 0, 8], yaw=float(rng.uniform(-3, 3)),
                               vel=rng.uniform(-2, 2, 3) if seed % 2 else None))
    for _ in range(int(rng.integers(200, 3000))):
        f.step(1 / 400)
    return f


def test_every_core_matches_itself_on_scalar_ops():
    dt = 1 / 400
    for seed in range(12):
        f = _airborne("copter", seed)
        ps, cs, ss, g, est = f._ps[0], f._cs[0], f._ss[0], f._gs[0], f._ests[0]
        c1, c2 = copy.copy(cs), copy.copy(cs)
        out1 = ccore.step.__wrapped__(c1, est, ss, g, dt, ScalarOps)
        out2 = ccore.step(c2, est, ss, g, dt, ScalarOps)
        assert _bits(out2) == _bits(out1)
        assert all(_bits(getattr(c1, k)) == _bits(getattr(c2, k)) for k in ccore.CopterCtrlState.FIELDS)
        for fn, args in ((shaping.shape_xy, (ss.px, ss.py, True, ss.vx, ss.vy, ss.ax, ss.ay, g.v_xy, g.a_xy, g.j_xy)),
                         (shaping.shape_z, (ss.pz, True, ss.vz, ss.az, g.v_up, g.v_dn, g.a_z, g.j_z))):
            r1, r2 = copy.copy(cs), copy.copy(cs)
            fn.__wrapped__(r1, *args, dt, ScalarOps)
            fn(r2, *args, dt, ScalarOps)
            assert all(_bits(getattr(r1, k)) == _bits(getattr(r2, k)) for k in ccore.CopterCtrlState.FIELDS)
        air = (2.0, -1.0, 0.5) if seed % 3 else None
        for ground_z in (0.0, ps.pz, ps.pz - 0.01):         # in the air, touching, pressed into it
            p1, p2 = copy.copy(ps), copy.copy(ps)
            mc.step.__wrapped__(p1, out1, f.airframe, dt, ground_z, ScalarOps, air)
            mc.step(p2, out1, f.airframe, dt, ground_z, ScalarOps, air)
            assert all(_bits(getattr(p1, k)) == _bits(getattr(p2, k)) for k in mc.QuadState.FIELDS)
        r1, r2 = copy.copy(cs), copy.copy(cs)
        ccore.relax.__wrapped__(r1, est, True, ScalarOps)
        ccore.relax(r2, est, True, ScalarOps)
        assert all(_bits(getattr(r1, k)) == _bits(getattr(r2, k)) for k in ccore.CopterCtrlState.FIELDS)

        f = _airborne("rover", seed)
        ps, ss, g, est = f._ps[0], f._ss[0], f._gs[0], f._ests[0]
        s1, s2 = copy.copy(ss), copy.copy(ss)
        v1 = rcore.step.__wrapped__(est, s1, g, dt, ScalarOps)
        v2 = rcore.step(est, s2, g, dt, ScalarOps)
        assert _bits(v1) == _bits(v2) and vars(s1).keys() == vars(s2).keys()
        assert all(_bits(getattr(s1, k)) == _bits(getattr(s2, k)) for k in vars(s1))
        p1, p2 = copy.copy(ps), copy.copy(ps)
        rphys.step.__wrapped__(p1, *v1, f.model, g, dt, ScalarOps, air)
        rphys.step(p2, *v1, f.model, g, dt, ScalarOps, air)
        assert all(_bits(getattr(p1, k)) == _bits(getattr(p2, k)) for k in rphys.RoverState.FIELDS)


def test_scalar_forms_keep_their_source_lines():
    """Tracebacks and line profiles of a scalar form point into the core's own source."""
    import inspect
    for core in (ccore.step, ccore.mix, ccore.relax, shaping.shape_xy, shaping.shape_z, mc.step, rcore.step,
                 rphys.step, _rules):
        src, first = inspect.getsourcelines(core.__wrapped__)
        lines = {n for _, _, n in core.scalar().__code__.co_lines() if n}
        assert first < min(lines) and max(lines) < first + len(src), core.__qualname__
