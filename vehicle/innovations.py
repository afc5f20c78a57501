"""The estimator's innovations, normalised: how far each fused measurement was from what
the filter predicted, in units of the predicted spread. ArduPilot's EKF reports these as
its test ratios (EKF_STATUS_REPORT, the EKF failsafe); vehicle/telemetry/ekf_status.py turns
them into that message.

Per vehicle, from the last fusion of each sensor (filterpy's `y` = z - Hx and `S` = HPH' + R
right after the update): the sum of squared innovations over the sum of their variances, for
GPS velocity (3 axes), GPS horizontal position (north, east) and baro height -- the form of
ArduPilot's velTestRatio / posTestRatio / hgtTestRatio before the gate is applied -- and the
estimator step of the last GPS fusion. Without aiding (vehicle/no_aiding.py) the position ratio
comes from the synthetic last-known-position fusion, as EKF3's does.
"""
from __future__ import annotations

import numpy as np

POS_TIMEOUT_S = 7.0     # EKF3 posRetryTimeNoVel_ms: without a GPS fix this long, no position


class InnovationLog:
    """Normalised innovations of n vehicles (see the module doc); -1 = no GPS fused yet."""

    def __init__(self, n: int) -> None:
        self.vel = np.zeros(n)
        self.pos = np.zeros(n)
        self.hgt = np.zeros(n)
        self.gps_step = np.full(n, -1, dtype=np.int64)

    def gps(self, i: int, y: np.ndarray, S: np.ndarray, step: int) -> None:
        """Vehicle i fused a GPS fix [pn, pe, pd, vn, ve, vd] at estimator step `step`."""
        yy = y.ravel().tolist()
        s = S.diagonal().tolist()
        self.pos[i] = (yy[0] * yy[0] + yy[1] * yy[1]) / (s[0] + s[1])
        self.vel[i] = (yy[3] * yy[3] + yy[4] * yy[4] + yy[5] * yy[5]) / (s[3] + s[4] + s[5])
        self.gps_step[i] = step

    def gps_all(self, y: np.ndarray, S: np.ndarray, step: int) -> None:
        """Every vehicle fused a GPS fix: y (n, 6), S (n, 6, 6)."""
        s = np.diagonal(S, axis1=1, axis2=2)
        y2 = y * y
        self.pos[:] = (y2[:, 0] + y2[:, 1]) / (s[:, 0] + s[:, 1])
        self.vel[:] = y2[:, 3:6].sum(axis=1) / s[:, 3:6].sum(axis=1)
        self.gps_step[:] = step

    def position(self, i: int, yn: float, ye: float, sn: float, se: float) -> None:
        """Vehicle i fused a horizontal position that is not a GPS fix (vehicle.no_aiding's
        last known position): innovations yn, ye (m) and their variances sn, se (m^2)."""
        self.pos[i] = (yn * yn + ye * ye) / (sn + se)

    def reset_horizontal(self, i: int) -> None:
        """Vehicle i stopped aiding: its velocity and position ratios are 0 (EKF3 resets them
        "to avoid false failing bad fusion tests")."""
        self.vel[i] = 0.0
        self.pos[i] = 0.0

    def baro(self, i: int, y: np.ndarray, S: np.ndarray) -> None:
        """Vehicle i fused a baro height."""
        e = y.item(0)
        self.hgt[i] = e * e / S.item(0)

    def baro_all(self, y: np.ndarray, S: np.ndarray) -> None:
        """Every vehicle fused a baro height: y (n, 1), S (n, 1, 1)."""
        self.hgt[:] = (y[:, 0] * y[:, 0]) / S[:, 0, 0]

    def keep(self, kf, missing: np.ndarray | None):
        """Before a batched update (BatchedKF `kf`) where the vehicles of `missing` (an (n,) mask,
        or None) have no measurement: their filter rows and log rows, for restore()."""
        if missing is None or not missing.any():
            return None
        m = missing.copy()
        return (m, kf.x[m].copy(), kf.P[m].copy(), self.vel[m].copy(), self.pos[m].copy(),
                self.hgt[m].copy(), self.gps_step[m].copy())

    def restore(self, kf, kept) -> None:
        """After the update: the kept vehicles as if it had not happened (nothing was fused)."""
        if kept is None:
            return
        m, x, P, vel, pos, hgt, step = kept
        kf.x[m], kf.P[m] = x, P
        self.vel[m], self.pos[m], self.hgt[m], self.gps_step[m] = vel, pos, hgt, step
