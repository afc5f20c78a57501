"""Seeded sensor models for a batch of vehicles: GPS, IMU (accelerometer + gyro), baro.

Every vehicle owns a numpy Generator seeded from its own seed, so vehicle i of a fleet
gets exactly the noise it would get alone with the same seed. Standard normals are drawn
in blocks of BLOCK steps per vehicle and consumed one row per step (every row has a
fixed slot per sensor, used or not), so results do not depend on which sensors fired.

Noise (1 sigma, white unless noted):
  GPS  10 Hz: position 0.3 m horizontal, 0.45 m vertical; velocity 0.1 m/s.
  IMU  every step: accelerometer 0.08 m/s^2 + constant bias N(0, 0.05); gyro 0.004 rad/s
       + constant bias N(0, 0.002).
  Baro 50 Hz: altitude 0.1 m.
  AHRS: attitude error as a first-order Gauss-Markov rotation vector (0.3 deg, 5 s),
       see vehicle.estimation.

Injected faults (ArduPilot SITL's SIM_*: vehicle.sim_faults, set_faults) change a vehicle's
readings after they are drawn, from the same normals: no GPS or baro reading (None in its
row), a GPS or baro step, a baro drift, wider noise. Without faults nothing is added.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from common.frames.batch import rotate, rotate_one
from vehicle import sim_faults

BLOCK = 256
# slots in one row of standard normals
_ACC, _GYR, _GPS_P, _GPS_V, _BARO, _AHRS = 0, 3, 6, 9, 12, 13
ROW = 16
GRAVITY = 9.80665


@dataclass
class SensorSpec:
    gps_rate: float = 10.0
    gps_pos_sigma: float = 0.3
    gps_alt_sigma: float = 0.45
    gps_vel_sigma: float = 0.1
    accel_sigma: float = 0.08
    accel_bias_sigma: float = 0.05
    gyro_sigma: float = 0.004
    gyro_bias_sigma: float = 0.002
    baro_rate: float = 50.0
    baro_sigma: float = 0.1
    ahrs_sigma: float = 0.3 * np.pi / 180.0
    ahrs_tau: float = 5.0


def vehicle_rngs(seed: int | Sequence[int], n: int) -> list[np.random.Generator]:
    """One Generator per vehicle: seed int -> entropy [seed, i]; a sequence gives each
    vehicle its own seed (entropy [seed_i, 0]), so vehicle i of a fleet built with
    seeds [.., s, ..] matches a single vehicle built with seeds [s]; a (seed, i) pair in
    the sequence is entropy [seed, i], vehicle i of a fleet seeded `seed`."""
    if isinstance(seed, (int, np.integer)):
        return [np.random.default_rng([int(seed), i]) for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"need {n} seeds, got {len(seeds)}")
    return [np.random.default_rng([int(x) for x in s] if isinstance(s, tuple) else [int(s), 0]) for s in seeds]


class NoiseSource:
    """Per-vehicle standard normals, one (n, width) slice per call, drawn in blocks."""

    def __init__(self, rngs: list[np.random.Generator], width: int, scale=1.0, offset=None):
        self.rngs = rngs
        self.n = len(rngs)
        self.width = width
        self.k = BLOCK
        self.block = np.empty((self.n, BLOCK, width))
        self.scale = scale
        self.offset = None if offset is None else np.asarray(offset, float)[:, None, :]
        self._by_step: list | None = None    # the block as Python floats, step by step, for next_rows

    def next(self) -> np.ndarray:
        """(n, width) = offset + scale * standard normals (each vehicle from its own stream)."""
        if self.k >= BLOCK:
            self._refill()
        z = self.block[:, self.k, :]
        self.k += 1
        return z

    def next_rows(self) -> Sequence[list[float]]:
        """next() as per-vehicle rows of Python floats (the same numbers): the block is
        listed (and regrouped by step) once per BLOCK steps, not sliced and listed every step."""
        if self.k >= BLOCK:
            self._refill()
        by_step = self._by_step
        if by_step is None:
            by_step = self._by_step = list(zip(*self.block.tolist()))
        k = self.k
        self.k = k + 1
        return by_step[k]

    def _refill(self) -> None:
        """The next BLOCK draws of every vehicle."""
        for i, r in enumerate(self.rngs):
            self.block[i] = r.standard_normal((BLOCK, self.width))
        if self.scale != 1.0:
            self.block *= self.scale
        if self.offset is not None:
            self.block += self.offset
        self.k = 0
        self._by_step = None


class Sensors:
    """Samples the sensors of n vehicles from truth arrays.

    The gyro is sampled every step (``gyro_noise``: the rate controller uses it); the
    accelerometer, GPS and baro at the estimator's epochs (``sample``), scheduled by
    step counts so every vehicle and every run sees the same sample times."""

    def __init__(self, rngs, spec: SensorSpec | None = None):
        self.spec = spec or SensorSpec()
        biases = np.array([r.standard_normal(6) for r in rngs]).reshape(len(rngs), 6)
        sp = self.spec
        self.accel_bias = biases[:, 0:3] * sp.accel_bias_sigma
        self._accel_bias_rows = self.accel_bias.tolist()
        self.gyro_bias = biases[:, 3:6] * sp.gyro_bias_sigma
        self.noise = NoiseSource(rngs, ROW)
        self.gyro_src = NoiseSource(rngs, 3, scale=sp.gyro_sigma, offset=self.gyro_bias)
        self.gps_pos = self.gps_vel = self.baro_alt = None
        self._gps_rows: tuple[list, list] | None = None     # sample_rows' latest GPS reading
        self.gps_fresh = False
        self.baro_fresh = False
        self.z = None
        # injected faults (vehicle.sim_faults), one SimFaults per vehicle; None: none anywhere
        self.faults: list | None = None
        self.fault_time = 0.0              # sim s since boot (a baro drift grows with it)
        self.gps_missing = self.baro_missing = None     # sample()'s (n,) masks of no reading

    def set_faults(self, faults: list) -> None:
        """Every vehicle's SimFaults (vehicle.sim_faults); readings change only where a
        vehicle's faults touch its sensors."""
        self.faults = None if all(f.sensors_ok for f in faults) else list(faults)

    def gyro_noise(self, rows: bool = False) -> np.ndarray | Sequence[list[float]]:
        """(n,3) gyro error this step: bias + white noise (+ SIM_GYR1_RND's) (rad/s, body FRD);
        rows=True: the same numbers as per-vehicle rows of Python floats (a few vehicles)."""
        if self.faults is not None:
            ge = self.gyro_src.next()
            ge = np.array([sim_faults.gyro_error(f, self.spec, b, e) for f, b, e
                           in zip(self.faults, self.gyro_bias.tolist(), ge.tolist())])
            return ge.tolist() if rows else ge
        return self.gyro_src.next_rows() if rows else self.gyro_src.next()

    def sample(self, gps: bool, baro: bool, pos, vel, acc_world, quat):
        """pos, vel, acc_world: (n,3) world NED truth; quat (n,4) xyzw body->world.
        Produces accel (body specific force) and, when asked, gps_pos/gps_vel and
        baro_alt (up positive, world z)."""
        sp = self.spec
        z = self.noise.next()
        self.z = z
        f_world = acc_world - np.array([0.0, 0.0, GRAVITY])
        self.accel = rotate(quat, f_world, inverse=True) + self.accel_bias + sp.accel_sigma * z[:, _ACC:_ACC + 3]
        self.gps_fresh = gps
        if gps:
            sig = np.array([sp.gps_pos_sigma, sp.gps_pos_sigma, sp.gps_alt_sigma])
            self.gps_pos = pos + sig * z[:, _GPS_P:_GPS_P + 3]
            self.gps_vel = vel + sp.gps_vel_sigma * z[:, _GPS_V:_GPS_V + 3]
            self._gps_rows = None
        self.baro_fresh = baro
        if baro:
            self.baro_alt = -pos[:, 2] + sp.baro_sigma * z[:, _BARO]
        if self.faults is not None:
            self._fault_arrays(gps, baro)
        else:
            self.baro_missing = None
            if gps:
                self.gps_missing = None

    def _fault_arrays(self, gps: bool, baro: bool) -> None:
        """sample()'s readings with the faults; gps_missing / baro_missing mark the vehicles
        without a reading this epoch (their array rows keep the unfaulted numbers)."""
        z = self.z.tolist()
        gp = self.gps_pos.tolist() if gps else None
        if gps:
            self.gps_missing = np.zeros(len(z), dtype=bool)
        self.baro_missing = np.zeros(len(z), dtype=bool) if baro else None
        for i, f in enumerate(self.faults):
            a, p, _, b = sim_faults.faulty_readings(f, self.fault_time, z[i], (_ACC, _BARO), self.spec,
                                                   self.accel[i].tolist(), gp[i] if gps else None, None,
                                                   float(self.baro_alt[i]) if baro else None)
            self.accel[i] = a
            if gps:
                if p is None:
                    self.gps_missing[i] = True
                else:
                    self.gps_pos[i] = p
            if baro:
                if b is None:
                    self.baro_missing[i] = True
                else:
                    self.baro_alt[i] = b

    def sample_rows(self, gps: bool, baro: bool, pos: list, vel: list, acc_world: list, quat: list):
        """sample() for a few vehicles on Python floats (numpy's per-call cost dominates
        there): pos, vel, acc_world are lists of [x, y, z] rows (world NED truth), quat of
        [x, y, z, w]. The same arithmetic in the same order, so the same numbers to the
        last bit. Returns (z, accel, gps_pos, gps_vel, baro_alt): this epoch's standard
        normals and the readings as lists of rows (gps_pos/gps_vel/baro_alt None when not
        sampled); the array attributes of sample() are not set."""
        sp = self.spec
        z = self.noise.next_rows()
        sa, sp_h, sp_v, sg_v, sb = sp.accel_sigma, sp.gps_pos_sigma, sp.gps_alt_sigma, sp.gps_vel_sigma, sp.baro_sigma
        accel = []
        for zi, a, q, b in zip(z, acc_world, quat, self._accel_bias_rows):
            rx, ry, rz = rotate_one(*q, a[0] - 0.0, a[1] - 0.0, a[2] - GRAVITY, -1.0)
            accel.append((rx + b[0] + sa * zi[_ACC], ry + b[1] + sa * zi[_ACC + 1], rz + b[2] + sa * zi[_ACC + 2]))
        gps_pos = gps_vel = baro_alt = None
        if gps:
            gps_pos = [(p[0] + sp_h * zi[_GPS_P], p[1] + sp_h * zi[_GPS_P + 1], p[2] + sp_v * zi[_GPS_P + 2])
                       for p, zi in zip(pos, z)]
            gps_vel = [(v[0] + sg_v * zi[_GPS_V], v[1] + sg_v * zi[_GPS_V + 1], v[2] + sg_v * zi[_GPS_V + 2])
                       for v, zi in zip(vel, z)]
            self._gps_rows = (gps_pos, gps_vel)
        if baro:
            baro_alt = [-p[2] + sb * zi[_BARO] for p, zi in zip(pos, z)]
        if self.faults is not None:
            return self._fault_rows(z, accel, gps_pos, gps_vel, baro_alt)
        return z, accel, gps_pos, gps_vel, baro_alt

    def _fault_rows(self, z, accel, gps_pos, gps_vel, baro_alt):
        """sample_rows()'s readings with the faults: a vehicle without a reading has None in
        its row of gps_pos / gps_vel / baro_alt."""
        t, sp, out = self.fault_time, self.spec, []
        for i, f in enumerate(self.faults):
            out.append(sim_faults.faulty_readings(f, t, z[i], (_ACC, _BARO), sp, accel[i],
                                                  gps_pos[i] if gps_pos is not None else None,
                                                  gps_vel[i] if gps_vel is not None else None,
                                                  baro_alt[i] if baro_alt is not None else None))
        accel = [o[0] for o in out]
        if gps_pos is not None:
            gps_pos, gps_vel = [o[1] for o in out], [o[2] for o in out]
            self._gps_rows = (gps_pos, gps_vel)
        if baro_alt is not None:
            baro_alt = [o[3] for o in out]
        return z, accel, gps_pos, gps_vel, baro_alt

    def gps_reading(self, i: int) -> list[float] | None:
        """Vehicle i's latest GPS reading [n, e, d, vn, ve, vd] (world NED m, m/s), from
        sample() or sample_rows(); None before the first."""
        rows = self._gps_rows
        if rows is not None:
            return None if rows[0][i] is None else [*rows[0][i], *rows[1][i]]
        if self.gps_pos is None or (self.gps_missing is not None and self.gps_missing[i]):
            return None
        return [*self.gps_pos[i].tolist(), *self.gps_vel[i].tolist()]
