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
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

BLOCK = 256
# slots in one row of standard normals
_ACC, _GYR, _GPS_P, _GPS_V, _BARO, _AHRS = 0, 3, 6, 9, 12, 13
ROW = 16


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
    seeds [.., s, ..] matches a single vehicle built with seeds [s]."""
    if isinstance(seed, (int, np.integer)):
        return [np.random.default_rng([int(seed), i]) for i in range(n)]
    seeds = list(seed)
    if len(seeds) != n:
        raise ValueError(f"need {n} seeds, got {len(seeds)}")
    return [np.random.default_rng([int(s), 0]) for s in seeds]


class NoiseSource:
    """Per-vehicle standard normals, one (n, ROW) slice per step."""

    def __init__(self, rngs: list[np.random.Generator]):
        self.rngs = rngs
        self.n = len(rngs)
        self.k = BLOCK
        self.block = np.empty((self.n, BLOCK, ROW))
        # constant biases drawn first, from each vehicle's own stream
        self.biases = np.array([r.standard_normal(6) for r in rngs]).reshape(self.n, 6)

    def next(self) -> np.ndarray:
        if self.k >= BLOCK:
            for i, r in enumerate(self.rngs):
                self.block[i] = r.standard_normal((BLOCK, ROW))
            self.k = 0
        z = self.block[:, self.k, :]
        self.k += 1
        return z


class Sensors:
    """Samples the sensors of n vehicles from truth arrays (n,3) each step."""

    def __init__(self, rngs, spec: SensorSpec | None = None):
        self.spec = spec or SensorSpec()
        self.noise = NoiseSource(rngs)
        sp = self.spec
        self.accel_bias = self.noise.biases[:, 0:3] * sp.accel_bias_sigma
        self.gyro_bias = self.noise.biases[:, 3:6] * sp.gyro_bias_sigma
        self.next_gps = 0.0
        self.next_baro = 0.0
        self.gps_pos = self.gps_vel = self.baro_alt = None
        self.gps_fresh = False
        self.baro_fresh = False
        self.z = None

    def sample(self, t: float, pos, vel, acc_world, R, rates):
        """pos, vel, acc_world: (n,3) world NED truth; R: (n,3,3) body->world; rates (n,3)
        body truth. Produces accel (body specific force), gyro, and, when due, gps_* and
        baro_alt (height above home, up positive)."""
        sp = self.spec
        z = self.noise.next()
        self.z = z
        f_world = acc_world - np.array([0.0, 0.0, 9.80665])
        f_body = np.einsum("nji,nj->ni", R, f_world)
        self.accel = f_body + self.accel_bias + sp.accel_sigma * z[:, _ACC:_ACC + 3]
        self.gyro = rates + self.gyro_bias + sp.gyro_sigma * z[:, _GYR:_GYR + 3]
        self.gps_fresh = t + 1e-9 >= self.next_gps
        if self.gps_fresh:
            self.next_gps += 1.0 / sp.gps_rate
            sig = np.array([sp.gps_pos_sigma, sp.gps_pos_sigma, sp.gps_alt_sigma])
            self.gps_pos = pos + sig * z[:, _GPS_P:_GPS_P + 3]
            self.gps_vel = vel + sp.gps_vel_sigma * z[:, _GPS_V:_GPS_V + 3]
        self.baro_fresh = t + 1e-9 >= self.next_baro
        if self.baro_fresh:
            self.next_baro += 1.0 / sp.baro_rate
            self.baro_alt = -pos[:, 2] + sp.baro_sigma * z[:, _BARO]
