"""Vehicle physics (pure, batched) and the two math backends the cores are written against.

The cores are written component by component ("structure of arrays"): every state
component is either a numpy array of shape (n,) (NumpyOps, the batched fleet) or a plain
Python float (ScalarOps, the single-vehicle fast path that avoids numpy's per-call
overhead). Only + - * /, comparisons, & | and the functions below are used, so one
source serves both.
"""
from __future__ import annotations

import math

import numpy as np


class NumpyOps:
    sqrt = staticmethod(np.sqrt)
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    atan = staticmethod(np.arctan)
    atan2 = staticmethod(np.arctan2)
    exp = staticmethod(np.exp)
    abs = staticmethod(np.abs)
    minimum = staticmethod(np.minimum)
    maximum = staticmethod(np.maximum)
    where = staticmethod(np.where)
    lnot = staticmethod(np.logical_not)
    any = staticmethod(np.any)
    all = staticmethod(np.all)

    @staticmethod
    def clip(x, lo, hi):
        return np.minimum(np.maximum(x, lo), hi)

    @staticmethod
    def sqrt_controller(err, k, lim, dt):
        """ArduPilot's sqrt controller on a non-negative error magnitude (see
        vehicle.control.shaping); the scalar version below computes the same numbers."""
        lin = lim / (k * k)
        out = np.where(err > lin, np.sqrt(2.0 * lim * np.maximum(err - 0.5 * lin, 0.0)), k * err)
        return np.minimum(out, err / dt)

    @staticmethod
    def zeros_like(x):
        return np.zeros_like(x)


class ScalarOps:
    sqrt = staticmethod(math.sqrt)
    sin = staticmethod(math.sin)
    cos = staticmethod(math.cos)
    atan = staticmethod(math.atan)
    atan2 = staticmethod(math.atan2)
    exp = staticmethod(math.exp)
    abs = staticmethod(abs)
    minimum = staticmethod(min)
    maximum = staticmethod(max)

    @staticmethod
    def where(c, a, b):
        return a if c else b

    @staticmethod
    def lnot(c):
        return not c

    any = staticmethod(bool)
    all = staticmethod(bool)

    @staticmethod
    def clip(x, lo, hi):
        return lo if x < lo else hi if x > hi else x

    @staticmethod
    def sqrt_controller(err, k, lim, dt):
        lin = lim / (k * k)
        out = math.sqrt(2.0 * lim * (err - 0.5 * lin)) if err > lin else k * err
        m = err / dt
        return out if out < m else m

    @staticmethod
    def zeros_like(x):
        return 0.0

