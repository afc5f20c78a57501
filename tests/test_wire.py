"""wire_clamp: rounding and clamping simulated values into MAVLink's integer fields."""
from __future__ import annotations

import math

import numpy as np

from vehicle.telemetry.wire import wire_clamp


def _reference(v, lo, hi):
    """The plain statement of the rule (what wire_clamp computes faster)."""
    if not math.isfinite(v):
        return 0
    return int(max(lo, min(hi, round(v))))


def test_wire_clamp_rounds_clamps_and_zeroes_what_is_not_finite():
    rng = np.random.default_rng(3)
    values = [*rng.normal(0.0, 4e4, 500).tolist(), 0.5, 1.5, -0.5, -2.5, 32767.4, 32767.6, -32768.5,
              float("nan"), float("inf"), -float("inf"), 7, -40000, np.float64(12.5), np.float64("nan"),
              np.int64(70000), True]
    for v in values:
        for lo, hi in ((0, 65535), (-32768, 32767), (-2**31, 2**31 - 1)):
            got = wire_clamp(v, lo, hi)
            assert got == _reference(v, lo, hi) and type(got) is int, (v, lo, hi, got)
