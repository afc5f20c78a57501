"""What the batched fleets share (vehicle/fleet.py: CopterFleet, RoverFleet): the guidance
target they take (Setpoint), the state they report (VehicleState), and FleetBase, their
storage and accessors: the true state, the estimate (sensors and estimator), the per-vehicle
parameters and the gains built from them, the air each vehicle flies in.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from common.frames import euler_from_quaternion

from vehicle import params_core
from vehicle.estimation import Estimator, output_step_scalar
from vehicle.innovations import POS_TIMEOUT_S
from vehicle.sensors import Sensors, SensorSpec, vehicle_rngs
from vehicle.sim_faults import NONE as NO_FAULTS
from vehicle.sim_faults import SimFaults, motor_multipliers


@dataclass
class Setpoint:
    """World-NED guidance target for one vehicle; None = not commanded."""
    pos: np.ndarray | Sequence[float] | None = None
    vel: np.ndarray | Sequence[float] | None = None
    acc: np.ndarray | Sequence[float] | None = None
    yaw: float | None = None
    yaw_rate: float | None = None
    level: bool = False
    roll: float | None = None        # attitude target (rad, with pitch): see vehicle/fleet.py's docstring
    pitch: float | None = None
    rates: Sequence[float] | None = None    # body roll, pitch rate feed-forward (rad/s)
    thrust: float | None = None      # collective 0..1 in place of the climb rate (attitude only)


@dataclass
class VehicleState:
    """One vehicle's kinematic state (world NED, body FRD, quaternion x,y,z,w)."""
    pos: np.ndarray
    vel: np.ndarray
    quat: np.ndarray
    rates: np.ndarray = field(default_factory=lambda: np.zeros(3))
    acc: np.ndarray = field(default_factory=lambda: np.zeros(3))
    t: float = 0.0

    @property
    def yaw(self) -> float:
        return self.euler[2]

    @property
    def euler(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) rad, ZYX."""
        return euler_from_quaternion(self.quat)


def vec3(v) -> list[float] | None:
    """A 3-vector (any array-like of 3 numbers) as 3 Python floats; None stays None."""
    return None if v is None else np.asarray(v, dtype=float).reshape(3).tolist()


def finite_or_zero(v: list[float]) -> list[float]:
    """v with every NaN or infinity replaced by 0.0 (numpy's nan_to_num with posinf=neginf=0,
    on floats: a setpoint is given to one vehicle at a time, where numpy calls cost most)."""
    return [c if math.isfinite(c) else 0.0 for c in v]


def finite_angle(a) -> float | None:
    """A finite angle/rate as float, else None (not commanded): a NaN yaw must never
    reach the controller."""
    if a is None:
        return None
    a = float(a)
    return a if math.isfinite(a) else None


class _Est:
    """Component view of estimator arrays for the controller."""

    def __init__(self, pos, vel, quat, rates, acc):
        self.px, self.py, self.pz = pos[:, 0], pos[:, 1], pos[:, 2]
        self.vx, self.vy, self.vz = vel[:, 0], vel[:, 1], vel[:, 2]
        self.qx, self.qy, self.qz, self.qw = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
        self.wx, self.wy, self.wz = rates[:, 0], rates[:, 1], rates[:, 2]
        self.ax, self.ay, self.az = acc[:, 0], acc[:, 1], acc[:, 2]


class _ScalarEst:
    __slots__ = ("px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "qx", "qy", "qz", "qw", "wx", "wy", "wz")


class SoA:
    """Arrays (n,) per field assembled from a list of scalar objects."""

    def __init__(self, objs, fields):
        for f in fields:
            setattr(self, f, np.array([getattr(o, f) for o in objs]))


def _stack_values(vals, inv):
    """One gains attribute over the fleet from the distinct gains objects' values `vals`
    (vehicle i has vals[inv[i]]): the shared value if all agree, else an (n,) array
    (lists/tuples of gains, e.g. CopterGains.rat, element by element)."""
    v0 = vals[0]
    if isinstance(v0, (list, tuple)):
        return type(v0)(_stack_values([v[m] for v in vals], inv) for m in range(len(v0)))
    if vals.count(v0) == len(vals):
        return v0
    return np.array(vals, dtype=float)[inv]


def _batched_gains(gs):
    """Gains for the vectorised step from per-vehicle gains objects (see _make_gains);
    vehicles with equal parameters share one object, so this works on the few distinct."""
    g0 = gs[0]
    if all(g is g0 for g in gs):
        return g0
    slot: dict[int, int] = {}
    distinct = []
    for g in gs:
        if id(g) not in slot:
            slot[id(g)] = len(distinct)
            distinct.append(g)
    inv = np.array([slot[id(g)] for g in gs])
    out = object.__new__(type(g0))
    out.__dict__.update({k: _stack_values([g.__dict__[k] for g in distinct], inv) for k in g0.__dict__})
    return out


SCALAR_MAX = 8
BATCHED_KF_MIN = 8     # estimator=True: per-vehicle filterpy up to this many vehicles, BatchedKF above


class FleetBase:
    """Shared storage and accessors. Two stores, one source of truth each:
    vector (numpy (n,) arrays per component, ``self._phys``) for big fleets, scalar
    (a list of per-vehicle float states, ``self._ps``) for small ones (n <= SCALAR_MAX),
    where Python floats beat numpy's per-call overhead several times over."""
    kind = "copter"
    STATE_FIELDS: tuple[str, ...] = ()

    def _init_common(self, n, params, seed, home, estimator, sensor_spec, scalar):
        self.n = int(n)
        self.home = np.zeros((self.n, 3)) if home is None else np.array(home, float).reshape(self.n, 3)
        base = params_core.merged(self.kind, params)
        self._vparams = [dict(base) for _ in range(self.n)]   # one parameter set per vehicle
        self._gs: list = [None] * self.n                     # per-vehicle gains (floats)
        self._gcache: dict = {}                              # parameter values -> shared gains
        self.sim_time = 0.0
        self.armed = np.zeros(self.n, dtype=bool)
        self._armed_l = [False] * self.n
        if estimator not in (True, False, "filterpy", "batched"):
            raise ValueError(f"estimator must be True, False, 'filterpy' or 'batched', not {estimator!r}")
        self.use_estimator = estimator is not False
        self.spec = sensor_spec or SensorSpec()
        self.scalar = (self.n <= SCALAR_MAX) if scalar is None else bool(scalar)
        if self.use_estimator:
            rngs = vehicle_rngs(seed, self.n)
            self.sensors = Sensors(rngs, self.spec)
            batched = estimator == "batched" or (estimator is True and self.n > BATCHED_KF_MIN)
            self.estimator = Estimator(self.n, self.home, self.spec, batched=batched)
        self._ests = [None] * self.n
        self._dqs = None
        self._est_view = None
        self.setpoints: list[Setpoint] = [Setpoint() for _ in range(self.n)]
        self.air: np.ndarray | None = None    # (n,3) air velocity, world NED m/s (wind); None = still
        self._air_rows: list | None = None    # the same as rows of floats (the scalar store)
        self._faults: list[SimFaults] = [NO_FAULTS] * self.n    # injected faults (vehicle.sim_faults)
        self._motor_mul: list | None = None    # per vehicle: motor multipliers or None; None: all 1

    def set_faults(self, i: int, faults: SimFaults) -> None:
        """Vehicle i's injected faults from now on (ArduPilot's SIM_*: vehicle.sim_faults)."""
        self._faults[i] = faults
        if self.use_estimator:
            self.sensors.set_faults(self._faults)
        self._motor_mul = motor_multipliers(self._faults)

    def faults_of(self, i: int) -> SimFaults:
        """Vehicle i's injected faults (vehicle.sim_faults.NONE: none)."""
        return self._faults[i]

    def set_air(self, air: np.ndarray | None) -> None:
        """Each vehicle's air velocity from now on ((n,3) world NED m/s), None: still air."""
        self.air = None if air is None else np.asarray(air, float).reshape(self.n, 3)
        self._air_rows = None if air is None else self.air.tolist()

    def _air_vec(self):
        a = self.air
        return None if a is None else (a[:, 0], a[:, 1], a[:, 2])

    # ---- true state --------------------------------------------------------------
    @property
    def phys(self):
        """Component arrays of the true state (each (n,))."""
        return SoA(self._ps, self.STATE_FIELDS) if self.scalar else self._phys

    def _stack(self, names):
        if not self.scalar:
            s = self._phys
            return np.column_stack([getattr(s, k) for k in names])
        return np.array([[getattr(o, k) for k in names] for o in self._ps], dtype=float)

    @property
    def pos(self) -> np.ndarray:
        """(n,3) true positions (scoring); est_pos is what the autopilot should use."""
        return self._stack(("px", "py", "pz"))

    @property
    def vel(self) -> np.ndarray:
        return self._stack(("vx", "vy", "vz"))

    @property
    def quat(self) -> np.ndarray:
        return self._stack(("qx", "qy", "qz", "qw"))

    @property
    def rates(self) -> np.ndarray:
        return self._stack(("wx", "wy", "wz"))

    @property
    def acc(self) -> np.ndarray:
        return self._stack(("ax", "ay", "az"))

    def truth(self, i: int) -> VehicleState:
        """True state of vehicle i (for scoring; the autopilot uses estimate())."""
        if self.scalar:
            s = self._ps[i]
            return VehicleState(np.array([s.px, s.py, s.pz]), np.array([s.vx, s.vy, s.vz]),
                                np.array([s.qx, s.qy, s.qz, s.qw]), np.array([s.wx, s.wy, s.wz]),
                                np.array([s.ax, s.ay, s.az]), self.sim_time)
        s = self._phys
        return VehicleState(np.array([s.px[i], s.py[i], s.pz[i]]), np.array([s.vx[i], s.vy[i], s.vz[i]]),
                            np.array([s.qx[i], s.qy[i], s.qz[i], s.qw[i]]),
                            np.array([s.wx[i], s.wy[i], s.wz[i]]), np.array([s.ax[i], s.ay[i], s.az[i]]),
                            self.sim_time)

    TRUTH_ROW = ("px", "py", "pz", "vx", "vy", "vz", "qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")
    _truth_snap: tuple | None = None       # (sim_time, rows) of one step

    def truth_row(self, i: int) -> list[float]:
        """truth(i) as Python floats, in TRUTH_ROW's order (SIM_STATE of every vehicle at
        10 Hz): a vector fleet lists all its vehicles' rows once per step."""
        if self.scalar:
            s = self._ps[i]
            return [getattr(s, k) for k in self.TRUTH_ROW]
        snap = self._truth_snap
        if snap is None or snap[0] != self.sim_time:
            s = self._phys
            snap = self._truth_snap = (self.sim_time,
                                       np.column_stack([getattr(s, k) for k in self.TRUTH_ROW]).tolist())
        return snap[1][i]

    # ---- estimate ----------------------------------------------------------------
    def _scalar_est_live(self) -> bool:
        return self.scalar and self.use_estimator and self._ests[0] is not None

    def _est_stack(self, names, arr_name):
        if not self.use_estimator:
            return self._stack(names)
        if self._scalar_est_live():
            return np.array([[getattr(o, k) for k in names] for o in self._ests], dtype=float)
        return getattr(self.estimator, arr_name).copy()

    @property
    def est_pos(self) -> np.ndarray:
        """(n,3) estimated positions, world NED."""
        return self._est_stack(("px", "py", "pz"), "pos")

    @property
    def est_vel(self) -> np.ndarray:
        return self._est_stack(("vx", "vy", "vz"), "vel")

    @property
    def est_quat(self) -> np.ndarray:
        """(n,4) estimated attitude, x,y,z,w body(FRD)->world(NED)."""
        return self._est_stack(("qx", "qy", "qz", "qw"), "quat")

    @property
    def est_rates(self) -> np.ndarray:
        return self._est_stack(("wx", "wy", "wz"), "rates")

    def estimate(self, i: int) -> VehicleState:
        """What the autopilot believes about vehicle i."""
        if not self.use_estimator:
            return self.truth(i)
        if self._scalar_est_live():
            o = self._ests[i]
            return VehicleState(np.array([o.px, o.py, o.pz]), np.array([o.vx, o.vy, o.vz]),
                                np.array([o.qx, o.qy, o.qz, o.qw]), np.array([o.wx, o.wy, o.wz]),
                                np.array([o.ax, o.ay, o.az]), self.sim_time)
        e = self.estimator
        return VehicleState(e.pos[i].copy(), e.vel[i].copy(), e.quat[i].copy(), e.rates[i].copy(),
                            e.acc[i].copy(), self.sim_time)

    _est_snap: tuple | None = None         # (sim_time, pos, vel, quat, rates) of one step

    def estimate_rows(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """estimate(i)'s pos, vel, quat, rates (the same values), for the autopilots of a big
        world that read every vehicle each tick: a vector fleet copies its estimate arrays
        once per step and hands out rows of that copy (read-only views) instead of building
        a VehicleState per vehicle."""
        if self.scalar:
            live = self._scalar_est_live()
            if not live and self.use_estimator:        # before the first filter epoch
                e = self.estimate(i)
                return e.pos, e.vel, e.quat, e.rates
            o = self._ests[i] if live else self._ps[i]
            # one fresh array, the four its views (each reader gets its own, as estimate() gives)
            b = np.array([o.px, o.py, o.pz, o.vx, o.vy, o.vz, o.qx, o.qy, o.qz, o.qw, o.wx, o.wy, o.wz])
            return b[0:3], b[3:6], b[6:10], b[10:13]
        snap = self._est_snap
        if snap is None or snap[0] != self.sim_time:          # stepped since: a new snapshot
            if self.use_estimator:
                e = self.estimator
                arrays = [e.pos.copy(), e.vel.copy(), e.quat.copy(), e.rates.copy()]
            else:
                arrays = [self.pos, self.vel, self.quat, self.rates]     # fresh stacks of the truth
            for a in arrays:
                a.flags.writeable = False
            snap = self._est_snap = (self.sim_time, *arrays)
        return snap[1][i], snap[2][i], snap[3][i], snap[4][i]

    def gps_fix(self, i: int) -> list[float] | None:
        """Vehicle i's latest GPS sample as [n, e, d, vn, ve, vd] (world NED m, m/s; the
        noisy receiver the estimator fuses), None before the first one; the truth when
        the fleet flies without an estimator (no GPS model)."""
        if not self.use_estimator:
            return self.truth_row(i)[0:6]
        return self.sensors.gps_reading(i)

    def estimate_ok(self, i: int) -> bool:
        """Position estimate good (pre-arm): always True when flying on truth."""
        if not self.use_estimator:
            return True
        e = self.estimator
        if not e.ok[i]:
            return False
        # EKF3 times GPS position out after POS_TIMEOUT_S without a fix
        return (e.k - 1 - int(e.innovations.gps_step[i])) * e.dt <= POS_TIMEOUT_S

    def set_armed(self, i: int, armed: bool) -> None:
        self.armed[i] = bool(armed)
        self._armed_l[i] = bool(armed)

    def setpoint(self, i: int) -> Setpoint:
        """The last Setpoint given to vehicle i."""
        return self.setpoints[i]

    @property
    def params(self) -> dict[str, float]:
        """Vehicle 0's parameters (each vehicle has its own: params_of(i))."""
        return self._vparams[0]

    def params_of(self, i: int) -> dict[str, float]:
        """Vehicle i's parameters by ArduPilot name (live; change them with set_params)."""
        return self._vparams[i]

    def gains_of(self, i: int):
        """Vehicle i's gains object (floats)."""
        return self._gs[i]

    def set_params(self, params: Mapping[str, float], i: int | None = None) -> None:
        """Live tuning by ArduPilot name; names this kind does not use are ignored.
        i=None: every vehicle; i=int: vehicle i only (each vehicle has its own parameters,
        as each ArduPilot does)."""
        if i is None:
            idx = range(self.n)
        else:
            i = int(i)
            if not 0 <= i < self.n:
                raise IndexError(f"vehicle {i} not in a fleet of {self.n}")
            idx = (i,)
        for j in idx:
            p = self._vparams[j]
            for k, v in params.items():
                if k in p:
                    p[k] = float(v)
        self._make_gains(idx)

    def _make_gains(self, idx=None) -> None:
        """Rebuild vehicle idx's gains (all: None), then self.gains for the batched step:
        one shared gains object when all vehicles agree (the step then runs on exactly the
        floats it always did), else a copy whose differing attributes are (n,) arrays,
        which broadcast in the vectorised core like the state arrays do."""
        cache = self._gcache
        for j in (range(self.n) if idx is None else idx):
            key = tuple(self._vparams[j].values())      # same key order for every vehicle
            g = cache.get(key)
            if g is None:
                if len(cache) > 4 * self.n + 16:
                    cache.clear()
                g = cache[key] = self._new_gains(self._vparams[j])
            self._gs[j] = g
        self.gains = _batched_gains(self._gs)

    def _sense_and_estimate_vec(self, dt):
        if not self.use_estimator:
            return None
        e = self.estimator
        self.sensors.fault_time = self.sim_time      # a baro drift grows with sim time
        ge = self.sensors.gyro_noise()
        if e.advance(dt):
            e.epoch(self.sensors, self.pos, self.vel, self.acc, self.quat, self.rates, ge)
        else:
            e.output_step(self.quat, self.rates, ge, dt)
        return _Est(e.pos, e.vel, e.quat, e.rates, e.acc)

    def _sense_and_estimate_scalar(self, dt) -> None:
        """Estimator for the scalar store, on Python floats throughout: truth, gyro error and
        the estimate pass as per-vehicle rows (vehicle.estimation.Estimator.epoch_rows),
        the output steps between epochs per vehicle."""
        if not self.use_estimator:
            return
        e = self.estimator
        self.sensors.fault_time = self.sim_time      # a baro drift grows with sim time
        ge = self.sensors.gyro_noise(rows=True)
        ps, ests = self._ps, self._ests
        if e.advance(dt):
            rows = e.epoch_rows(self.sensors, [[s.px, s.py, s.pz] for s in ps], [[s.vx, s.vy, s.vz] for s in ps],
                                [[s.ax, s.ay, s.az] for s in ps], [[s.qx, s.qy, s.qz, s.qw] for s in ps],
                                [[s.wx, s.wy, s.wz] for s in ps], ge)
            dqs = self._dqs = []
            for i, r in enumerate(rows):          # r: pos, vel, bias, acc, quat, dq, rates, ahrs_err
                o = ests[i] or _ScalarEst()
                o.px, o.py, o.pz, o.vx, o.vy, o.vz = r[0:6]
                o.ax, o.ay, o.az, o.qx, o.qy, o.qz, o.qw = r[9:16]
                o.wx, o.wy, o.wz = r[20:23]
                ests[i] = o
                dqs.append(r[16:20])
        else:
            dqs = self._dqs
            for i in range(self.n):
                output_step_scalar(ests[i], ps[i], dqs[i], ge[i], dt)
