"""The scoring's measures: minimum times, errors and their statistics, the attitude's ground-point error.

Pure functions on numbers and on tools.run_data's RunData; tools.run_summary (one run),
tools.family_summary (a family) and tools.hover_stats (the hovers) score with them.
Positions are world NED, m; times sim s.
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import ground_point
from tools.run_data import RunData
from tools.run_ids import PARAM_DEFAULTS, SCORING_PARAMS  # noqa: F401 (their users import them here too)


def minimum_time(d: float, v: float, a: float, j: float) -> float:
    """Shortest rest-to-rest time over distance d with speed v, acceleration a, jerk j limits.

    The symmetric jerk-limited (S-curve) profile. For long moves (the cruise speed v
    and the acceleration a are both reached) this is the design's d/v + v/a + a/j;
    shorter moves peak below v (and, shorter still, below a), and the time is
    solved exactly for those cases so the ratio stays meaningful on short legs.
    """
    if d < 0 or v <= 0 or a <= 0 or j <= 0:
        raise ValueError("minimum_time needs d >= 0 and v, a, j > 0")
    if d == 0:
        return 0.0

    def t_acc(vp: float) -> float:   # time to go from rest to vp (and the same to stop)
        return vp / a + a / j if vp >= a * a / j else 2.0 * math.sqrt(vp / j)

    # distance of accelerating to vp and back to rest: vp * t_acc(vp)
    if v * t_acc(v) <= d:
        return d / v + t_acc(v)
    # no cruise: the peak speed vp solves vp * t_acc(vp) = d
    vp = a / 2.0 * (-(a / j) + math.sqrt((a / j) ** 2 + 4.0 * d / a))
    if vp < a * a / j:                          # acceleration limit not reached either
        vp = (d * math.sqrt(j) / 2.0) ** (2.0 / 3.0)
    return 2.0 * t_acc(vp)


def rms(x: np.ndarray) -> float:
    """Root mean square of x (nan when empty)."""
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def horizontal_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Horizontal (north, east) distance between points a and b (..., 3), m."""
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def world_transforms(data: RunData, child: str, vehicle: str = "drone") -> list[tuple[float, tuple]]:
    """The recorded transforms world -> `child`: the bridge's <vehicle>_origin -> child moved by
    the static world -> <vehicle>_origin (a translation, from GPS_GLOBAL_ORIGIN); tlogs from
    before the origin frames have world -> child itself."""
    origin = vehicle + "_origin"
    rows = data.transforms.get((origin, child))
    off = data.statics.get(("world", origin))
    if not rows or off is None:
        return data.transforms.get(("world", child), [])
    ox, oy, oz = off[:3]
    return [(t, (v[0] + ox, v[1] + oy, v[2] + oz, *v[3:])) for t, v in rows]


def ground_point_errors(transforms: list[tuple[float, tuple]]) -> tuple[np.ndarray, np.ndarray]:
    """Attitude-caused ground-point error of each recorded world -> drone-frame transform.

    The ground point is (0, 0, h) in the drone frame, h = the drone's height (-z of its
    origin in world), mapped to world (common.frames.batch.ground_point, the follow's own);
    its horizontal distance from the frame's own origin is what the attitude adds
    (h·sin(tilt) for a full-attitude frame, 0 for a yaw-only one). Returns (stamps, errors).
    """
    if not transforms:
        return np.zeros(0), np.zeros(0)
    a = np.array([(t, *v) for t, v in transforms], float)
    t, xyz, q = a[:, 0], a[:, 1:4], a[:, 4:8]
    gp = ground_point(xyz, q, -xyz[:, 2])
    return t, np.hypot(gp[:, 0] - xyz[:, 0], gp[:, 1] - xyz[:, 1])


def stat(x: np.ndarray) -> dict[str, float | int]:
    """RMS, max and count of the finite values of x (None, None, 0 when there are none)."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    if not x.size:
        return {"rms": None, "max": None, "n": 0}
    return {"rms": rms(x), "max": float(np.max(x)), "n": int(x.size)}


def in_window(t: np.ndarray, t0: float | None, t1: float | None) -> np.ndarray:
    """Mask of the stamps t within [t0, t1] (an open end when None)."""
    m = np.ones(len(t), bool)
    if t0 is not None:
        m &= t >= t0
    if t1 is not None:
        m &= t <= t1
    return m
