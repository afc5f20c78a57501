"""State estimation: what the autopilot believes, from noisy sensors (vehicle.sensors).

Position/velocity: one filterpy ``KalmanFilter`` per vehicle (or, for big fleets,
``BatchedKF``: the same equations over a vehicle axis, checked against filterpy), 9 states
[p (3), v (3), b (3)] in world NED, where b is the accelerometer bias expressed in the
world frame (slowly varying). The filter is predicted at ``kf_rate`` (100 Hz) with the
IMU specific force rotated to world by the attitude estimate plus gravity, averaged
sampled at the epoch, and corrected with GPS position + velocity
(10 Hz) and baro altitude (sampled at 50 Hz; EKF3 takes a height sample only when it is more
than SENSOR_INTERVAL_MIN_MS after the last one it took, so every third: 16.7 Hz). Between filter epochs the output is dead-reckoned
with the IMU every step (vectorised) and reset to the filter state at each epoch, like
the output predictor of ArduPilot's EKF.

Attitude: not filtered here. The attitude estimate is truth rotated by a small AHRS
error, a first-order Gauss-Markov rotation vector (0.3 deg, 5 s), and the body rates
are the gyro (noise + bias). This models a converged AHRS without simulating one.
The gyro is sampled every step; accelerometer, GPS (10 Hz) and baro (50 Hz) at filter
epochs, scheduled by step counts.

``ok`` (estimate_ok): at least ``min_gps`` GPS fixes fused and position variance below
``ok_var`` on every axis.

Without GPS for 15 s a filter stops aiding (vehicle.no_aiding, EKF3's AID_NONE): it fuses
its last known horizontal position with each baro height, so its velocity stays bounded;
the next fix resets it onto GPS.

Speed (a filter epoch of one vehicle): the filters are filterpy's own predict/update on
fixed-size matrices, fed from reused buffers (GPS z, the predict's u). Both measurements
observe states directly with uncorrelated noise (H rows unit vectors, R diagonal), so the
update fuses them one scalar at a time as ArduPilot's EKF3 fuses GPS (FuseVelPosNED): a
division per component, no inverse of the 6x6 S (vehicle.sequential_kf). Around the filters, per-vehicle epochs run on Python floats
(sensors, AHRS error, rotations), the same operations in the same order as the vectorised
form, taking truth and handing out the estimate as per-vehicle rows (epoch_rows).
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import quat_mul, quat_mul_one, rotate, rotate_one
from vehicle.innovations import InnovationLog
from vehicle.no_aiding import NoAiding
from vehicle.sequential_kf import SequentialForms, SequentialKalmanFilter, fuse_scalars_batched

G = np.array([0.0, 0.0, 9.80665])
# EKF3's sensorIntervalMin_ms (AP_NavEKF3.cpp): readBaroData takes a new height sample only when
# it is more than this after the last one taken, which keeps its measurement buffer from filling
SENSOR_INTERVAL_MIN_MS = 50


def make_kf(dt: float, pos0, accel_sigma: float, gps_pos_sigma: float, gps_alt_sigma: float,
            gps_vel_sigma: float) -> SequentialKalmanFilter:
    """The 9-state filter [p, v, b] (world NED, m, m/s, m/s^2) for epochs dt s apart, at
    pos0, with white-acceleration process noise and the GPS noise of the sensor spec."""
    kf = SequentialKalmanFilter(dim_x=9, dim_z=6, dim_u=3)
    F = np.eye(9)
    F[0:3, 3:6] = np.eye(3) * dt
    F[0:3, 6:9] = -np.eye(3) * 0.5 * dt * dt
    F[3:6, 6:9] = -np.eye(3) * dt
    kf.F = F
    B = np.zeros((9, 3))
    B[0:3] = np.eye(3) * 0.5 * dt * dt
    B[3:6] = np.eye(3) * dt
    kf.B = B
    kf.H = np.hstack([np.eye(6), np.zeros((6, 3))])
    kf.R = np.diag([gps_pos_sigma ** 2] * 2 + [gps_alt_sigma ** 2] + [gps_vel_sigma ** 2] * 3)
    q_acc = (accel_sigma * 2.0) ** 2          # white acceleration uncertainty (incl. attitude error)
    Q = np.zeros((9, 9))
    Q[0:3, 0:3] = np.eye(3) * q_acc * dt ** 4 / 4
    Q[0:3, 3:6] = Q[3:6, 0:3] = np.eye(3) * q_acc * dt ** 3 / 2
    Q[3:6, 3:6] = np.eye(3) * q_acc * dt ** 2
    Q[6:9, 6:9] = np.eye(3) * (0.03) ** 2 * dt   # bias random walk (fast enough to absorb AHRS tilt error)
    kf.Q = Q
    kf.x = np.zeros(9)
    kf.x[0:3] = pos0
    kf.P = np.diag([25.0] * 3 + [4.0] * 3 + [0.1 ** 2] * 3)
    return kf


class BatchedKF:
    """The same filter as ``make_kf`` for n vehicles at once: filterpy's predict (x = Fx + Bu,
    P = FPF' + Q) and the update of vehicle.sequential_kf (the measurement's components fused
    one after the other as scalars) written over a leading vehicle axis; an update whose H or
    R has no sequential form takes filterpy's (K = PH' inv(S), Joseph form). Used for fleets
    too big for per-vehicle filterpy objects; tests check it against them."""

    def __init__(self, template: SequentialKalmanFilter, x0: np.ndarray):
        n = len(x0)
        self.F, self.B, self.Q = template.F.copy(), template.B.copy(), template.Q.copy()
        self.H, self.R = template.H.copy(), template.R.copy()
        self.x = np.tile(template.x, (n, 1))
        self.x[:, 0:3] = x0
        self.P = np.tile(template.P, (n, 1, 1))
        self._I = np.eye(template.dim_x)
        self._forms = SequentialForms()

    def predict(self, u: np.ndarray) -> None:
        self.x = self.x @ self.F.T + u @ self.B.T
        self.P = self.F @ self.P @ self.F.T + self.Q

    def update(self, z: np.ndarray, R: np.ndarray | None = None, H: np.ndarray | None = None) -> None:
        R = self.R if R is None else R
        H = self.H if H is None else H
        y = z - self.x @ H.T
        plan = self._forms.get(H, R)
        if plan.idx is not None:
            self.y, self.S = y, self.P[(slice(None),) + plan.ix] + R     # the innovations, as filterpy keeps them
            self.x, self.P = fuse_scalars_batched(self.x, self.P, plan.idx, z, plan.r)
            return
        PHT = self.P @ H.T
        S = H @ PHT + R
        K = PHT @ np.linalg.inv(S)
        self.y, self.S = y, S
        self.x = self.x + np.einsum("nij,nj->ni", K, y)
        I_KH = self._I - K @ H
        self.P = I_KH @ self.P @ I_KH.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)


ROW = 26          # one vehicle's epoch output row (see Estimator.rows)
_ROW_SLICES = {"pos": (0, 3), "vel": (3, 6), "bias": (6, 9), "acc": (9, 12), "quat": (12, 16),
               "dq": (16, 20), "rates": (20, 23), "ahrs_err": (23, 26)}


class _RowBacked:
    """An (n, k) array attribute of Estimator that a per-vehicle epoch leaves as Python rows
    (Estimator.rows): built from them only when someone reads it (a small fleet's step reads
    the rows, never the arrays, so it pays no numpy calls for them)."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        arrays = obj._arrays
        if arrays is None:
            arrays = obj._materialise()
        return arrays[self.name]

    def __set__(self, obj, value) -> None:
        arrays = obj._arrays
        if arrays is None:
            arrays = obj._materialise()
        arrays[self.name] = value


class Estimator:
    """Batched front end over per-vehicle filterpy filters (or BatchedKF).

    Per step (cheap, ``output_step`` vectorised or ``output_step_scalar`` per vehicle):
    dead-reckon pos/vel with the last epoch's world acceleration; rates = gyro; attitude
    = truth (x) AHRS error. At filter epochs (``epoch``, every kf_rate^-1 s, counted in
    steps): sample accelerometer/GPS/baro, predict + correct each filter, reset the
    output to the filter state. With per-vehicle filters the epoch's sensor and attitude
    arithmetic runs on Python floats, vehicle by vehicle (the same operations in the same
    order as the vectorised form, so the same numbers).

    After such an epoch ``rows`` holds each vehicle's output as one list of ROW floats
    (pos, vel, bias, acc, quat, dq, rates, ahrs_err, in that order); the array attributes
    (pos, vel, ...) are built from it on first read."""

    pos, vel, bias, acc = _RowBacked(), _RowBacked(), _RowBacked(), _RowBacked()      # (n,3) world NED
    quat, dq, rates, ahrs_err = _RowBacked(), _RowBacked(), _RowBacked(), _RowBacked()

    def __init__(self, n: int, home: np.ndarray, spec, kf_rate: float = 100.0,
                 min_gps: int = 10, ok_var: float = 0.5, batched: bool = False):
        self.n = n
        self.batched = bool(batched)
        self.spec = spec
        self.kf_rate = kf_rate
        self.min_gps = min_gps
        self.ok_var = ok_var
        self.home = np.asarray(home, float).reshape(n, 3).copy()
        self.kfs = None
        self.H_baro = np.zeros((1, 9))
        self.H_baro[0, 2] = 1.0
        self.R_baro = np.array([[spec.baro_sigma ** 2]])
        self.rows: list[list[float]] | None = None
        self._arrays: dict[str, np.ndarray] | None = {}
        self.pos = self.home.copy()
        self.vel = np.zeros((n, 3))
        self.bias = np.zeros((n, 3))
        self.acc = np.zeros((n, 3))
        self.quat = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
        self.dq = np.tile([0.0, 0.0, 0.0, 1.0], (n, 1))
        self.rates = np.zeros((n, 3))
        self.ahrs_err = np.zeros((n, 3))
        self.gps_count = np.zeros(n, dtype=int)
        self.ok = np.zeros(n, dtype=bool)
        self.k = 0
        self.innovations = InnovationLog(n)     # read by EKF_STATUS_REPORT
        self.no_aiding = NoAiding(n, spec)      # EKF3's AID_NONE after a long GPS loss

    def _materialise(self) -> dict[str, np.ndarray]:
        """The array attributes from `rows` (one array, the attributes views of it: numpy's
        per-array cost paid once)."""
        buf = np.array(self.rows, dtype=float).reshape(self.n, ROW)
        self._arrays = {k: buf[:, lo:hi] for k, (lo, hi) in _ROW_SLICES.items()}
        return self._arrays

    def part(self, name: str, i: int) -> list[float]:
        """Vehicle i's attribute `name` (pos, vel, bias, acc, quat, dq, rates, ahrs_err) as
        floats, from `rows` while they are current (no arrays built)."""
        if self._arrays is None:
            lo, hi = _ROW_SLICES[name]
            return self.rows[i][lo:hi]
        return self._arrays[name][i].tolist()

    def _row_part(self, name: str) -> list:
        """Attribute `name` as a list of per-vehicle rows, from `rows` while they are current."""
        if self._arrays is None:
            lo, hi = _ROW_SLICES[name]
            return [r[lo:hi] for r in self.rows]
        return self._arrays[name].tolist()

    def _setup(self, dt: float) -> None:
        sp = self.spec
        self.dt = dt
        self.n_kf = max(1, round(1.0 / (self.kf_rate * dt)))
        self.kf_dt = self.n_kf * dt
        # GPS and baro on the epochs nearest their rates (a loop slower than kf_rate runs its
        # filter every step: ArduPilot's EKF3 predicts once per loop when the loop is slower)
        self.n_gps = self.n_kf * max(1, round(1.0 / (sp.gps_rate * self.kf_dt)))
        self.n_baro = self.n_kf * max(1, round(1.0 / (sp.baro_rate * self.kf_dt)))
        # a baro sample is fused when at least this many steps after the last one taken
        self._baro_gap = SENSOR_INTERVAL_MIN_MS * 1000 // round(dt * 1e6) + 1
        never = -self._baro_gap          # the step of each vehicle's last baro sample taken
        self._baro_taken = np.full(self.n, never) if self.batched else [never] * self.n
        # AHRS error: first-order Gauss-Markov, a = exp(-T/tau), drive sigma sqrt(1 - a^2)
        self._ahrs_a = a = math.exp(-self.kf_dt / sp.ahrs_tau)
        self._ahrs_drive = sp.ahrs_sigma * math.sqrt(1 - a * a)
        mk = lambda p0: make_kf(self.kf_dt, p0, sp.accel_sigma, sp.gps_pos_sigma,  # noqa: E731
                                sp.gps_alt_sigma, sp.gps_vel_sigma)
        if self.batched:
            self.kfs = []
            self.bkf = BatchedKF(mk(np.zeros(3)), self.home)
        else:
            self.kfs = [mk(self.home[i]) for i in range(self.n)]
            self._z_gps = np.zeros(6)            # measurement buffer (filterpy copies z)
            self._u = np.zeros(3)

    def advance(self, dt: float) -> bool:
        """Count one step; True when this step is a filter epoch."""
        if self.kfs is None:
            self._setup(dt)
        k = self.k
        self.k += 1
        return k % self.n_kf == 0

    def output_step(self, truth_quat: np.ndarray, truth_rates: np.ndarray, gyro_err: np.ndarray, dt: float):
        """Vectorised per-step output (non-epoch steps)."""
        self.vel = self.vel + self.acc * dt
        self.pos = self.pos + self.vel * dt
        self.attitude(truth_quat, truth_rates, gyro_err)

    def attitude(self, truth_quat, truth_rates, gyro_err):
        self.rates = truth_rates + gyro_err
        self.quat = quat_mul(truth_quat, self.dq)

    def epoch(self, sensors, pos, vel, acc, quat, rates, gyro_err) -> None:
        """Filter epoch from truth arrays (n,3)/(n,4) (via the sensor models)."""
        k = self.k - 1
        gps = k % self.n_gps == 0
        baro = k % self.n_baro == 0
        if self.batched:
            self._epoch_batched(sensors, gps, baro, pos, vel, acc, quat, rates, gyro_err)
        else:
            self.epoch_rows(sensors, pos.tolist(), vel.tolist(), acc.tolist(), quat.tolist(), rates.tolist(),
                            gyro_err.tolist())

    def epoch_rows(self, sensors, pos: list, vel: list, acc: list, quat: list, rates: list, gyro_err: list) -> list:
        """epoch() for per-vehicle filters from truth and gyro error as lists of per-vehicle
        rows of floats (a small fleet's own form: no arrays built either way); returns
        `rows`, each vehicle's output (a list of ROW floats)."""
        if self.batched:            # (a small fleet made to use BatchedKF: its arrays, as rows)
            self.epoch(sensors, *(np.array(a, dtype=float) for a in (pos, vel, acc, quat, rates, gyro_err)))
            return np.hstack([self._arrays[k] for k in _ROW_SLICES]).tolist()
        k = self.k - 1
        return self._epoch_filters(sensors, k % self.n_gps == 0, k % self.n_baro == 0, pos, vel, acc, quat,
                                   rates, gyro_err)

    def _epoch_batched(self, sensors, gps, baro, pos, vel, acc, quat, rates, gyro_err) -> None:
        sensors.sample(gps, baro, pos, vel, acc, quat)
        z = sensors.z
        self.ahrs_err = self._ahrs_a * self.ahrs_err + self._ahrs_drive * z[:, 13:16]
        dq = np.column_stack([0.5 * self.ahrs_err, np.ones(self.n)])
        self.dq = dq / np.linalg.norm(dq, axis=1, keepdims=True)
        self.attitude(quat, rates, gyro_err)
        acc_w = rotate(self.quat, sensors.accel) + G
        b = self.bkf
        b.predict(acc_w)
        if gps:
            self._aiding_batched(b, sensors)
            kept = self.innovations.keep(b, sensors.gps_missing)
            b.update(np.hstack([sensors.gps_pos, sensors.gps_vel]))
            self.innovations.gps_all(b.y, b.S, self.k - 1)
            self.innovations.restore(b, kept)
        if baro:
            step = self.k - 1
            skip = step - self._baro_taken < self._baro_gap
            if sensors.baro_missing is not None:
                skip |= sensors.baro_missing
            if not skip.all():
                kept = self.innovations.keep(b, skip)
                b.update(-sensors.baro_alt[:, None], R=self.R_baro, H=self.H_baro)
                self.innovations.baro_all(b.y, b.S)
                self.innovations.restore(b, kept)
                self._baro_taken[~skip] = step
                na = self.no_aiding
                for i in np.flatnonzero(na.active):
                    if not skip[i]:
                        na.fuse(i, b.x[i], b.P[i], self.innovations)
        self.pos = b.x[:, 0:3].copy()
        self.vel = b.x[:, 3:6].copy()
        self.bias = b.x[:, 6:9].copy()
        if gps:
            self.gps_count += 1 if sensors.gps_missing is None else ~sensors.gps_missing
            pv = np.diagonal(b.P, axis1=1, axis2=2)[:, 0:3]
            self.ok = (self.gps_count >= self.min_gps) & np.all(pv < self.ok_var, axis=1)
        self.acc = acc_w - self.bias

    def _aiding_batched(self, b: BatchedKF, sensors) -> None:
        """At a GPS epoch of BatchedKF: the vehicles without a fix for too long stop aiding,
        those not aiding that have one resume (vehicle.no_aiding)."""
        na, missing, log = self.no_aiding, sensors.gps_missing, self.innovations
        step = self.k - 1
        for i in np.flatnonzero(na.active):
            if missing is None or not missing[i]:
                na.resume(i, b.x[i], b.P[i], np.hstack([sensors.gps_pos[i], sensors.gps_vel[i]]))
        if missing is not None:
            for i in np.flatnonzero(missing):
                if self._aiding_lost(i, step):
                    na.stop(i, b.x[i], b.P[i], log)

    def _aiding_lost(self, i: int, step: int) -> bool:
        """Vehicle i, with no GPS fix at estimator step `step`, should stop aiding now."""
        age = (step - int(self.innovations.gps_step[i])) * self.dt
        return self.no_aiding.due(i, self.gps_count[i] >= self.min_gps, age)

    def _epoch_filters(self, sensors, gps, baro, pos, vel, acc, Q, rates, gyro_err) -> list:
        """Per-vehicle filterpy filters; sensors, AHRS error and rotations on floats (every
        input a list of per-vehicle rows)."""
        z, accel, gps_pos, gps_vel, baro_alt = sensors.sample_rows(gps, baro, pos, vel, acc, Q)
        a, drive, g = self._ahrs_a, self._ahrs_drive, float(G[2])     # a float: rows stay Python floats
        zg, u = self._z_gps, self._u
        log, step = self.innovations, self.k - 1
        noaid = self.no_aiding.active
        taken, gap = self._baro_taken, self._baro_gap
        rows = []
        for i, (kf, zi, qt, w, ge, err, f) in enumerate(zip(self.kfs, z, Q, rates, gyro_err,
                                                            self._row_part("ahrs_err"), accel)):
            ex = a * err[0] + drive * zi[13]
            ey = a * err[1] + drive * zi[14]
            ez = a * err[2] + drive * zi[15]
            hx, hy, hz = 0.5 * ex, 0.5 * ey, 0.5 * ez
            norm = math.sqrt(hx * hx + hy * hy + hz * hz + 1.0)
            dx, dy, dz, dw = hx / norm, hy / norm, hz / norm, 1.0 / norm
            qx, qy, qz, qw = quat_mul_one(qt[0], qt[1], qt[2], qt[3], dx, dy, dz, dw)
            awx, awy, awz = rotate_one(qx, qy, qz, qw, f[0], f[1], f[2])
            u[0], u[1], u[2] = awx + 0.0, awy + 0.0, awz + g
            kf.predict(u=u)
            fix = gps and gps_pos[i] is not None        # None: no fix (vehicle.sim_faults)
            if fix:
                zg[0:3] = gps_pos[i]
                zg[3:6] = gps_vel[i]
                if noaid[i]:
                    self.no_aiding.resume(i, kf.x, kf.P, zg)
                kf.update(zg)
                log.gps(i, kf.y, kf.S, step)
            elif gps and self._aiding_lost(i, step):
                self.no_aiding.stop(i, kf.x, kf.P, log)
            if baro and baro_alt[i] is not None and step - taken[i] >= gap:
                taken[i] = step
                # a scalar z (filterpy takes one for dim_z 1): the same y, and its copy of z is cheap
                kf.update(-baro_alt[i], R=self.R_baro, H=self.H_baro)
                log.baro(i, kf.y, kf.S)
                if noaid[i]:
                    self.no_aiding.fuse(i, kf.x, kf.P, log)
            x = kf.x.tolist()            # the row: x, then acc, quat, dq, rates, AHRS error
            x += (awx + 0.0 - x[6], awy + 0.0 - x[7], awz + g - x[8], qx, qy, qz, qw, dx, dy, dz, dw,
                  w[0] + ge[0], w[1] + ge[1], w[2] + ge[2], ex, ey, ez)
            rows.append(x)
            if fix:
                self.gps_count[i] += 1
                P = kf.P
                self.ok[i] = (self.gps_count[i] >= self.min_gps and P[0, 0] < self.ok_var
                              and P[1, 1] < self.ok_var and P[2, 2] < self.ok_var)
        self.rows = rows
        self._arrays = None          # the array attributes: from the rows when read
        return rows



def output_step_scalar(o, ph, dq, ge, dt):
    """Per-step output for one vehicle on floats: o has px..vz, ax..az (world accel),
    qx..qw, wx..wz; ph is the true scalar state; dq the AHRS error (x,y,z,w); ge the gyro
    error (3,)."""
    o.vx += o.ax * dt
    o.vy += o.ay * dt
    o.vz += o.az * dt
    o.px += o.vx * dt
    o.py += o.vy * dt
    o.pz += o.vz * dt
    o.wx = ph.wx + ge[0]
    o.wy = ph.wy + ge[1]
    o.wz = ph.wz + ge[2]
    ax, ay, az, aw = ph.qx, ph.qy, ph.qz, ph.qw
    bx, by, bz, bw = dq
    o.qx = aw * bx + ax * bw + ay * bz - az * by
    o.qy = aw * by - ax * bz + ay * bw + az * bx
    o.qz = aw * bz + ax * by - ay * bx + az * bw
    o.qw = aw * bw - ax * bx - ay * by - az * bz
