"""The estimator without aiding: EKF3's AID_NONE (AP_NavEKF3_Control.cpp setAidingMode,
AP_NavEKF3_PosVelFusion.cpp SelectVelPosFusion / FuseVelPosNED), for the 9-state filter of
vehicle/estimation.py (x = [p (3), v (3), b (3)], world NED m, m/s, m/s^2).

EKF3 stops aiding once no GPS position or velocity has been fused for AIDING_LOSS_S
(tiltDriftTimeMax_ms). Then:
- on entry it keeps the current horizontal position as the last known one, resets the
  horizontal velocity to zero (variance: the GPS velocity noise) and the position to the last
  known one (variance: the GPS position noise), and zeroes the velocity and position test
  ratios;
- with every height fusion it fuses that last known position as a synthetic observation of
  the horizontal position, with EK3_NOAID_M_NSE (default 10 m) as its noise, always passing
  the gate and never teaching the accelerometer bias; this keeps the horizontal velocity
  from running away (dead reckoning on the IMU alone diverges);
- when a GPS fix is fused again it resets position and velocity to the fix (AID_ABSOLUTE).
towerlink's differences: the filter has no attitude states (the synthetic observation
constrains position and velocity only), and the noise is EK3_NOAID_M_NSE's default on the
ground too (EKF3 uses 0.5 m while disarmed). Pure: no clocks, the caller hands in the ages.
"""
from __future__ import annotations

import numpy as np

AIDING_LOSS_S = 15.0      # EKF3 tiltDriftTimeMax_ms: no GPS fused this long, aiding stops
NOAID_NOISE = 10.0        # m, EK3_NOAID_M_NSE's default: the synthetic position's noise
_POS, _VEL, _BIAS = (0, 1), (3, 4), slice(6, 9)    # the horizontal position and velocity states


def _zero_cross(P: np.ndarray, idx: tuple[int, int]) -> None:
    """Zero the rows and columns of states idx in P (in place), as EKF3's zeroRows/zeroCols."""
    for k in idx:
        P[k, :] = 0.0
        P[:, k] = 0.0


def fuse_position_ne(x: np.ndarray, P: np.ndarray, ne, r: float) -> tuple[float, float, float, float]:
    """Fuse an observation `ne` (north, east m) of the horizontal position with variance r (m^2)
    into x (9,) and P (9, 9), in place: the two axes one after the other (EKF3's sequential
    fusion), the accelerometer-bias gains zero. Returns the innovations (estimate minus
    observation, EKF3's sign) and their variances before fusion (north, east, var_n, var_e)."""
    yn, ye = float(x[0] - ne[0]), float(x[1] - ne[1])
    sn, se = float(P[0, 0] + r), float(P[1, 1] + r)
    for k in _POS:
        s = P[k, k] + r
        K = P[:, k] / s
        K[_BIAS] = 0.0
        innov = x[k] - ne[k]
        x -= K * innov
        P -= np.outer(K, P[k, :])
    P[:] = 0.5 * (P + P.T)
    return yn, ye, sn, se


class NoAiding:
    """Which of n vehicles' filters are not aiding, and their last known positions; the
    transitions in and out (see the module doc). spec: the SensorSpec (GPS noise sigmas)."""

    def __init__(self, n: int, spec) -> None:
        self.active = [False] * n                  # per vehicle: not aiding (EKF3's AID_NONE)
        self.last_known: list[tuple[float, float] | None] = [None] * n    # north, east m
        self._pos_var = spec.gps_pos_sigma ** 2
        self._vel_var = spec.gps_vel_sigma ** 2

    def due(self, i: int, aligned: bool, gps_age: float) -> bool:
        """True when vehicle i should stop aiding now: it has been aiding on GPS (aligned: as
        many fixes fused as the estimator wants before its position counts) and has fused
        none for more than AIDING_LOSS_S (gps_age s)."""
        return aligned and not self.active[i] and gps_age > AIDING_LOSS_S

    def stop(self, i: int, x: np.ndarray, P: np.ndarray, log) -> None:
        """Vehicle i stops aiding: its last known position is where the filter is; velocity
        and position reset as EKF3 resets them; the log's velocity and position ratios 0."""
        self.active[i] = True
        self.last_known[i] = (float(x[0]), float(x[1]))
        _zero_cross(P, _VEL + _POS)
        x[3] = x[4] = 0.0
        P[3, 3] = P[4, 4] = self._vel_var
        P[0, 0] = P[1, 1] = self._pos_var
        log.reset_horizontal(i)

    def fuse(self, i: int, x: np.ndarray, P: np.ndarray, log) -> None:
        """Vehicle i, not aiding, fuses its last known position (with a height fusion)."""
        yn, ye, sn, se = fuse_position_ne(x, P, self.last_known[i], NOAID_NOISE ** 2)
        log.position(i, yn, ye, sn, se)

    def resume(self, i: int, x: np.ndarray, P: np.ndarray, fix) -> None:
        """Vehicle i has a GPS fix again ([n, e, d, vn, ve, vd]): aiding restarts with the
        horizontal position and velocity reset to the fix (EKF3's ResetPosition/ResetVelocity)."""
        self.active[i] = False
        self.last_known[i] = None
        _zero_cross(P, _VEL + _POS)
        x[0], x[1], x[3], x[4] = fix[0], fix[1], fix[3], fix[4]
        P[0, 0] = P[1, 1] = self._pos_var
        P[3, 3] = P[4, 4] = self._vel_var
