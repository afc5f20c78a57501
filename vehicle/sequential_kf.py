"""Sequential scalar fusion: a Kalman update without a matrix inverse, for measurements that
observe states directly with uncorrelated noise.

When every row of H is a unit vector (observation j reads state idx[j]) and R is diagonal
(variance r[j]), the joint update K = PH' S^-1 equals fusing the observations one after the
other as scalars, which needs one division each: for each j, with p the current row idx[j] of
P (P symmetric), s = p[idx[j]] + r[j] and innovation e = z[j] - x[idx[j]],

    x <- x + (p / s) e,        P <- P - p p' / s.

This is how ArduPilot's EKF3 fuses GPS velocity and position (AP_NavEKF3_PosVelFusion.cpp,
FuseVelPosNED: "sequential fusion" of the six components, each a scalar gain and the
covariance update P - KHP written for a direct observation of one state). The same numbers
as the joint update in exact arithmetic; in floating point they differ in the last bits.
p p' / s is computed as (p_i p_j) / s so the update is exactly symmetric; entries where p_i
is zero are skipped, which gives the bits of the dense formula (P - 0 and x + 0 are exact),
so the batched form (vehicle.estimation.BatchedKF) computes the same numbers densely.

filterpy's KalmanFilter has this as ``update_sequential`` (one call per component, on column
vectors); at a few microseconds of numpy calls per component it costs five times the joint
update here, so ``SequentialKalmanFilter.update`` runs the loop on Python floats over the
nonzero part of each row instead, keeping filterpy's update() signature and attributes.
"""
from __future__ import annotations

import math
from itertools import compress

import numpy as np
from filterpy.kalman import KalmanFilter


_WRITE_BACK_MAX = 48    # P entries (about) worth writing one by one rather than rebuilding P


class SequentialForm:
    """What a sequential update needs from one (H, R) pair: the observed states ``idx``, their
    variances ``r`` and the index of S in P (``ix``), all None when H or R has no sequential
    form (a row of H not a unit vector, or R not diagonal)."""

    __slots__ = ("h_bytes", "r_bytes", "idx", "r", "ix")

    def __init__(self, H: np.ndarray, R: np.ndarray) -> None:
        self.h_bytes, self.r_bytes = H.tobytes(), R.tobytes()
        self.idx = self.r = self.ix = None
        m = H.shape[0]
        if R.shape != (m, m) or np.count_nonzero(R - np.diag(np.diagonal(R))):
            return
        if not (np.count_nonzero(H, axis=1) == 1).all() or not (H.max(axis=1) == 1.0).all():
            return
        self.idx = H.argmax(axis=1).tolist()
        self.r = np.diagonal(R).tolist()
        self.ix = np.ix_(self.idx, self.idx)


class SequentialForms:
    """The SequentialForm of the last few (H, R) pairs seen (a filter's own and those passed
    per call), by identity and checked against their contents, so H and R may be replaced or
    edited freely."""

    KEPT = 8

    def __init__(self) -> None:
        self._forms: dict[tuple[int, int], SequentialForm] = {}

    def get(self, H: np.ndarray, R: np.ndarray) -> SequentialForm:
        key = (id(H), id(R))
        form = self._forms.get(key)
        if form is None or form.h_bytes != H.tobytes() or form.r_bytes != R.tobytes():
            if len(self._forms) >= self.KEPT:
                self._forms.clear()
            form = self._forms[key] = SequentialForm(H, R)
        return form


def fuse_scalars(x: list, P: list, idx: list, z: list, r: list) -> tuple[set, float]:
    """Fuse observations z[j] of states idx[j] with variances r[j] one after the other into
    x (a list of floats) and P (a list of rows of floats), in place (see the module doc).
    Returns the supports (tuples of state indices) whose rows and columns of P, and entries
    of x, may have changed (entries outside every support's block are untouched), and the
    squared Mahalanobis distance y' S^-1 y of the whole measurement, which is the sum of the
    scalar steps' e^2 / s (sequential fusion whitens the innovations)."""
    states = range(len(x))
    supports = set()
    d2 = 0.0
    for s, zs, rs in zip(idx, z, r):
        row = P[s][:]
        c = 1.0 / (row[s] + rs)
        e = zs - x[s]
        d2 += e * e * c
        nz = tuple(compress(states, row))          # the nonzero entries (NaN counts as nonzero)
        supports.add(nz)
        for i in nz:
            ri = row[i]
            x[i] += ri * c * e
            Pi = P[i]
            for j in nz:
                Pi[j] -= ri * row[j] * c
    return supports, d2


def fuse_scalars_batched(x: np.ndarray, P: np.ndarray, idx: list, z: np.ndarray, r: list):
    """fuse_scalars for a leading vehicle axis: x (n, dim_x), P (n, dim_x, dim_x), z (n, m);
    returns the new (x, P), the same numbers as fuse_scalars vehicle by vehicle."""
    for a, s in enumerate(idx):
        row = P[:, s, :].copy()
        c = 1.0 / (row[:, s] + r[a])
        e = z[:, a] - x[:, s]
        x = x + row * c[:, None] * e[:, None]
        P = P - row[:, :, None] * row[:, None, :] * c[:, None, None]
    return x, P


class SequentialKalmanFilter(KalmanFilter):
    """filterpy's KalmanFilter (1-D state x) whose update() fuses a measurement with unit-row
    H and diagonal R as scalars, one after the other (see the module doc), without S^-1.

    After such an update x, P, y (= z - Hx before the update), S (= HPH' + R before it), z,
    x_post, P_post and mahalanobis are what filterpy's update leaves; K and SI, which
    sequential fusion never forms, are None; x and P are updated in place where P is sparse (only the blocks
    that change are written). Any other H or R (or a column-vector x) goes to filterpy's update.
    H and R are recognised by their contents, so they may be replaced or edited freely."""

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0) -> None:
        super().__init__(dim_x, dim_z, dim_u)
        self._forms = SequentialForms()

    def update(self, z, R=None, H=None) -> None:
        """filterpy's update(z, R=None, H=None): sequential when H and R allow it."""
        Rm = self.R if R is None else (R if isinstance(R, np.ndarray) else np.eye(self.dim_z) * R)
        plan = self._forms.get(self.H if H is None else H, Rm)
        if z is None or plan.idx is None or self.x.ndim != 1:
            return super().update(z, R, H)
        self._log_likelihood = self._likelihood = None
        idx, r = plan.idx, plan.r
        zl = np.ravel(z).tolist() if isinstance(z, (np.ndarray, list, tuple)) else [float(z)]
        xa, Pa = self.x, self.P
        x, P = xa.tolist(), Pa.tolist()
        self.y = np.array([zj - x[s] for s, zj in zip(idx, zl)])
        self.S = Pa[plan.ix] + Rm if len(idx) > 1 else np.array([[P[idx[0]][idx[0]] + r[0]]])
        self.K = self.SI = None
        supports, d2 = fuse_scalars(x, P, idx, zl, r)
        self._mahalanobis = math.sqrt(d2)
        if sum(len(b) * len(b) for b in supports) > _WRITE_BACK_MAX:
            self.x, self.P = np.array(x), np.array(P)
        else:                          # a sparse P: the changed blocks, written back in place
            for b in supports:
                for i in b:
                    xa[i] = x[i]
                    Pi = P[i]
                    for j in b:
                        Pa[i, j] = Pi[j]
        self.z = np.array(zl)
        self.x_post = self.x.copy()
        self.P_post = self.P.copy()
