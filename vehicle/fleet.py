"""Batched vehicle groups the autopilot drives: CopterFleet and RoverFleet (pure, no I/O).

Each fleet steps all its vehicles together, one fixed step per ``step(dt)`` (400 Hz is
the design rate): controller (on the estimate) -> physics -> sensors -> estimator
(-> land detector). The autopilot maps modes and MAVLink commands to ``Setpoint``s; it
never touches physics. Truth (``truth(i)``, ``pos``...) is for scoring only; the
autopilot reads ``estimate(i)`` / ``est_pos`` etc. and ``estimate_ok(i)`` (pre-arm).

How modes use Setpoints (copter; all world NED, z down, ground at the vehicle's home z):
  hold / LOITER without RC / BRAKE: Setpoint()                    velocity 0: brakes, holds
  position (GUIDED, AUTO, RTL legs): Setpoint(pos=p, yaw=psi)     jerk/accel/speed limited
                                     by WPNAV_SPEED(_UP/_DN), WPNAV_ACCEL(_Z), PSC_JERK_XY/Z
  follow / moving target:            Setpoint(pos=p, vel=v)       vel is feed-forward
  velocity (GUIDED velocity):        Setpoint(vel=v)              pos None (acc optional)
  takeoff:                           set_armed(i, True) + Setpoint(pos=(x, y, ground_z - alt))
  land:                              Setpoint(pos=(x, y, nan), vel=(0, 0, LAND_SPEED)),
                                     built by land_setpoint(i); NaN in pos = that axis
                                     group (xy or z) is velocity-controlled. landed(i) goes
                                     true ~1 s after touch-down; the autopilot then disarms.
  STABILIZE without RC:              Setpoint(level=True)         roll/pitch level, altitude
                                     and yaw held, no horizontal control (drifts)
  attitude (GUIDED's attitude target): Setpoint(roll=r, pitch=p, yaw=psi, vel=(0, 0, vz))
                                     lean to (r, p) at heading psi (ZYX, rad; |r|, |p| <= 80 deg),
                                     no horizontal control, climb at -vz; rates=(p, q) body
                                     roll/pitch and yaw_rate: feed-forward of a moving target;
                                     thrust=t (0..1): collective t instead of the climb rate
  yaw: yaw=psi slews at ATC_RATE_Y_MAX; yaw_rate=r turns at r; neither = hold heading.
An armed copter on the ground idles (MOT_SPIN_ARM) until its setpoint is above ground
(position z more than 0.25 m above ground, or a climb velocity). Disarmed: motors stop.
Non-finite parts of a Setpoint count as not commanded.

Rover (skid-steer): Setpoint(pos=p) drive there and stop (WP_RADIUS, no orbiting);
Setpoint(pos=p, vel=v) follow a moving target; Setpoint(vel=v) drive at a velocity;
Setpoint() stop and hold; Setpoint(yaw=psi) turns in place when stopped, as does
Setpoint(yaw_rate=r) (yaw wins when both are given). z is ignored.

Parameters are per vehicle (ArduPilot names): set_params(params, i) tunes vehicle i only,
set_params(params) all of them; params_of(i) / gains_of(i) read one vehicle's. The batched
step's self.gains holds floats where the vehicles agree and (n,) arrays where they differ.

Speed: fleets of n <= SCALAR_MAX step vehicle by vehicle on Python floats (the same core
source on the ScalarOps backend) -- ~30 us per copter step on truth, ~65 us with sensors
and filterpy; bigger fleets step as numpy arrays (~0.8 us per drone-step at 1000). With
estimator=True fleets above BATCHED_KF_MIN use BatchedKF, filterpy's equations batched.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from common.frames import euler_from_quaternion

from vehicle import params_core
from vehicle.control import copter as ccore
from vehicle.control import rover as rcore
from vehicle.estimation import Estimator, output_step_scalar
from vehicle.physics import NumpyOps, ScalarOps
from vehicle.physics import multicopter as mc
from vehicle.physics import rover as rphys
from vehicle.sensors import Sensors, SensorSpec, vehicle_rngs


@dataclass
class Setpoint:
    """World-NED guidance target for one vehicle; None = not commanded."""
    pos: np.ndarray | Sequence[float] | None = None
    vel: np.ndarray | Sequence[float] | None = None
    acc: np.ndarray | Sequence[float] | None = None
    yaw: float | None = None
    yaw_rate: float | None = None
    level: bool = False
    roll: float | None = None        # attitude target (rad, with pitch): see the module docstring
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


def _vec(v) -> np.ndarray | None:
    return None if v is None else np.asarray(v, dtype=float).reshape(3)


def _angle(a) -> float | None:
    """A finite angle/rate as float, else None (not commanded): a NaN yaw must never
    reach the controller."""
    if a is None:
        return None
    a = float(a)
    return a if math.isfinite(a) else None


MAX_LEAN = math.radians(80.0)   # an attitude target's roll and pitch are flown within this


def _attitude_values(sp: Setpoint, flags: dict) -> dict:
    """The controller's attitude-target values of `sp` (zeros, and flags att/use_thrust
    False, when it has no finite roll and pitch). A thrust target flies no vertical loop:
    its velocity target only tells the ground logic whether the copter wants up (ArduCopter
    takes off on a positive thrust)."""
    roll, pitch = _angle(sp.roll), _angle(sp.pitch)
    att = roll is not None and pitch is not None
    thrust = _angle(sp.thrust) if att else None
    flags.update(att=att, use_thrust=thrust is not None)
    if not att:
        return dict(tan_roll=0.0, tan_pitch=0.0, wx=0.0, wy=0.0, thrust=0.0)
    rates = np.zeros(3) if sp.rates is None else np.nan_to_num(np.asarray(sp.rates, float), posinf=0.0, neginf=0.0)
    out = dict(tan_roll=math.tan(max(-MAX_LEAN, min(MAX_LEAN, roll))),
               tan_pitch=math.tan(max(-MAX_LEAN, min(MAX_LEAN, pitch))),
               wx=float(rates[0]), wy=float(rates[1]), thrust=0.0 if thrust is None else thrust)
    if thrust is not None:
        out.update(vx=0.0, vy=0.0, vz=-1.0 if thrust > 0 else 0.0)
    return out


class _Est:
    """Component view of estimator arrays for the controller."""

    def __init__(self, pos, vel, quat, rates):
        self.px, self.py, self.pz = pos[:, 0], pos[:, 1], pos[:, 2]
        self.vx, self.vy, self.vz = vel[:, 0], vel[:, 1], vel[:, 2]
        self.qx, self.qy, self.qz, self.qw = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
        self.wx, self.wy, self.wz = rates[:, 0], rates[:, 1], rates[:, 2]


class _ScalarEst:
    __slots__ = ("px", "py", "pz", "vx", "vy", "vz", "ax", "ay", "az", "qx", "qy", "qz", "qw", "wx", "wy", "wz")


class _SoA:
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


class _FleetBase:
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
        self._air_rows: list | None = None

    def set_air(self, air: np.ndarray | None) -> None:
        """The air velocity each vehicle flies in from now on ((n,3) world NED m/s, the wind
        of vehicle.physics.wind), or None for still air."""
        self.air = None if air is None else np.asarray(air, float).reshape(self.n, 3)
        self._air_rows = None if air is None else self.air.tolist()

    def _air_vec(self):
        a = self.air
        return None if a is None else (a[:, 0], a[:, 1], a[:, 2])

    def _air_of(self, i: int):
        return None if self.air is None else self._air_rows[i]

    # ---- true state --------------------------------------------------------------
    @property
    def phys(self):
        """Component arrays of the true state (each (n,))."""
        return _SoA(self._ps, self.STATE_FIELDS) if self.scalar else self._phys

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
            e = self.estimate(i)
            return e.pos, e.vel, e.quat, e.rates
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
        return True if not self.use_estimator else bool(self.estimator.ok[i])

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
        ge = self.sensors.gyro_noise()
        if e.advance(dt):
            e.epoch(self.sensors, self.pos, self.vel, self.acc, self.quat, self.rates, ge)
        else:
            e.output_step(self.quat, self.rates, ge, dt)
        return _Est(e.pos, e.vel, e.quat, e.rates)

    def _sense_and_estimate_scalar(self, dt) -> None:
        """Estimator for the scalar store: epochs vectorised, output steps on floats."""
        if not self.use_estimator:
            return
        e = self.estimator
        ge = self.sensors.gyro_noise()
        if e.advance(dt):
            e.epoch(self.sensors, self.pos, self.vel, self.acc, self.quat, self.rates, ge)
            P, V, A = e.pos.tolist(), e.vel.tolist(), e.acc.tolist()
            Q, W = e.quat.tolist(), e.rates.tolist()
            for i in range(self.n):
                o = self._ests[i] or _ScalarEst()
                o.px, o.py, o.pz = P[i]
                o.vx, o.vy, o.vz = V[i]
                o.ax, o.ay, o.az = A[i]
                o.qx, o.qy, o.qz, o.qw = Q[i]
                o.wx, o.wy, o.wz = W[i]
                self._ests[i] = o
            self._dqs = e.dq.tolist()
        else:
            ge = ge.tolist()
            for i in range(self.n):
                output_step_scalar(self._ests[i], self._ps[i], self._dqs[i], ge[i], dt)


def _copter_core(ph, c, est, sp, armed, landed, ground_z, g, af, dt, xp, air=None):
    """Controller + physics for one step (backend-generic). Returns the 'running' mask."""
    climb = xp.where(sp.use_pos_z, sp.pz < ground_z - 0.25, sp.vz < -0.05)
    idle = landed & xp.lnot(climb)
    stop = idle | xp.lnot(armed)
    if xp.any(stop):
        ccore.relax(c, est, stop, xp)
    f = ccore.step(c, est, sp, g, dt, xp)
    om = af.omega_max
    run = armed & xp.lnot(idle)
    if xp.all(run):
        cmd = [fi * om for fi in f]
    else:
        idle_w = xp.where(armed, om * g.spin_arm, 0.0)
        cmd = [xp.where(run, fi * om, idle_w) for fi in f]
    mc.step(ph, cmd, af, dt, ground_z, xp, air)
    return run


def _land_detect(c, e, ph, run, armed, landed, timer, g, dt, xp):
    """ArduPilot-style land detector: armed, low thrust demand, not moving, for
    LAND_DETECT_TIME. Cleared by a take-off (thrust demand near hover and moving).
    Disarmed: landed = resting on the ground."""
    coll = xp.where(run, c.coll, 0.0)
    quiet = (coll < 0.8 * g.hover) & (xp.abs(e.vz) < 0.3) & (e.vx * e.vx + e.vy * e.vy < 1.0)
    timer = xp.where(armed & quiet, timer + dt, 0.0)
    took_off = run & (c.coll > 0.9 * g.hover) & xp.lnot(quiet)
    landed = xp.where(armed, (landed & xp.lnot(took_off)) | (timer >= g.land_time), ph.ground)
    return landed, timer


class CopterFleet(_FleetBase):
    """n quad-X copters. params: ArduPilot names (vehicle.params_core.COPTER_PARAMS).

    seed: int (vehicle i seeded with [seed, i]) or a sequence of per-vehicle seeds.
    home: (n,3) world NED start positions; each vehicle's ground is at its home z.
    estimator: True = sensors + Kalman filter (per-vehicle filterpy KalmanFilter for
    n <= BATCHED_KF_MIN, else the identical-math numpy BatchedKF); 'filterpy' or 'batched'
    force one; False flies on truth with no sensor noise (the 1000-drone benchmark).
    scalar: None = automatic (n <= SCALAR_MAX): small fleets step vehicle by vehicle on
    Python floats (same source code, ScalarOps backend); large fleets step as numpy
    arrays. Both give the same numbers (tests/test_fleet.py)."""
    kind = "copter"
    STATE_FIELDS = mc.QuadState.FIELDS

    def __init__(self, n: int, params: Mapping[str, float] | None = None, seed: int | Sequence[int] = 0,
                 home: np.ndarray | None = None, estimator: bool | str = True, airframe: mc.QuadAirframe | None = None,
                 sensor_spec: SensorSpec | None = None, yaw: np.ndarray | float | None = None,
                 scalar: bool | None = None):
        self._init_common(n, params, seed, home, estimator, sensor_spec, scalar)
        self.airframe = airframe or mc.QuadAirframe()
        self.ground_z = self.home[:, 2].copy()
        self._make_gains()
        yaws = np.broadcast_to(np.asarray(0.0 if yaw is None else yaw, float), (self.n,))
        if self.scalar:
            # plain lists: the per-vehicle loop reads and writes them without numpy calls
            self._landed = [True] * self.n
            self._land_timer = [0.0] * self.n
            self._run = [False] * self.n
            self._ps = [mc.QuadState(None, pos=self.home[i], yaw=float(yaws[i])) for i in range(self.n)]
            self._cs = [ccore.CopterCtrlState(None) for _ in range(self.n)]
            self._ss = [ccore.SetpointArrays(None) for _ in range(self.n)]
            self._gz = [float(z) for z in self.ground_z]
            for i in range(self.n):
                ccore.relax(self._cs[i], self._ps[i], True, ScalarOps)
        else:
            self._landed = np.ones(self.n, dtype=bool)
            self._land_timer = np.zeros(self.n)
            self._run = np.zeros(self.n, dtype=bool)
            self._phys = mc.QuadState(self.n, pos=self.home, yaw=yaws)
            self._ctrl = ccore.CopterCtrlState(self.n)
            self.sp = ccore.SetpointArrays(self.n)
            ccore.relax(self._ctrl, self._phys, np.ones(self.n, dtype=bool))
        for i in range(self.n):
            self.set_setpoint(i, Setpoint())

    def _new_gains(self, p):
        return ccore.CopterGains(p)

    @property
    def ctrl(self):
        """Component arrays of the controller state (reference, integrators, coll)."""
        return _SoA(self._cs, ccore.CopterCtrlState.FIELDS) if self.scalar else self._ctrl

    def set_setpoint(self, i: int, sp: Setpoint) -> None:
        """Give vehicle i a new guidance target (see the module docstring for modes).
        pos components that are NaN leave that axis group (xy or z) velocity-controlled."""
        self.setpoints[i] = sp
        pos, vel, acc = _vec(sp.pos), _vec(sp.vel), _vec(sp.acc)
        yaw, yaw_rate = _angle(sp.yaw), _angle(sp.yaw_rate)
        vel = np.zeros(3) if vel is None else np.nan_to_num(vel, posinf=0.0, neginf=0.0)
        acc = np.zeros(3) if acc is None else np.nan_to_num(acc, posinf=0.0, neginf=0.0)
        if pos is None:
            use_xy = use_z = False
            pos = np.zeros(3)
        else:
            use_xy = bool(np.isfinite(pos[0]) and np.isfinite(pos[1]))
            use_z = bool(np.isfinite(pos[2]))
            pos = np.where(np.isfinite(pos), pos, 0.0)
        vals = dict(px=pos[0], py=pos[1], pz=pos[2], vx=vel[0], vy=vel[1], vz=vel[2],
                    ax=acc[0], ay=acc[1], az=acc[2],
                    yaw=0.0 if yaw is None else yaw, yaw_rate=0.0 if yaw_rate is None else yaw_rate)
        flags = dict(use_pos_xy=use_xy, use_pos_z=use_z, level=bool(sp.level), use_yaw=yaw is not None)
        vals.update(_attitude_values(sp, flags))
        if self.scalar:
            o = self._ss[i]
            for k, v in vals.items():
                setattr(o, k, float(v))
            for k, v in flags.items():
                setattr(o, k, v)
        else:
            for k, v in vals.items():
                getattr(self.sp, k)[i] = v
            for k, v in flags.items():
                getattr(self.sp, k)[i] = v

    def land_setpoint(self, i: int, xy: Sequence[float] | None = None) -> Setpoint:
        """Descend at LAND_SPEED over xy (default: where the estimate is)."""
        if xy is None:
            xy = self.estimate(i).pos[:2]
        return Setpoint(pos=np.array([xy[0], xy[1], np.nan]), vel=np.array([0.0, 0.0, self._gs[i].land_speed]))

    def landed(self, i: int) -> bool:
        """On the ground: land detector when armed (~LAND_DETECT_TIME s of low thrust and
        no motion), resting on the ground when disarmed."""
        return bool(self._landed[i])

    @property
    def landed_mask(self) -> np.ndarray:
        return np.array(self._landed, dtype=bool)

    def rotor_power(self, i: int) -> float:
        """Shaft power (W) vehicle i's rotors absorb now (physics.multicopter.rotor_power):
        what its battery pays for thrust."""
        s = self._ps[i] if self.scalar else self._phys
        p = mc.rotor_power(s, self.airframe)
        return float(p if self.scalar else p[i])

    def motor_outputs(self, i: int) -> tuple[float, float, float, float]:
        """Vehicle i's rotor speeds as fractions of full speed (0..1), ArduPilot's motor
        order (front-right, back-left, front-left, back-right): SERVO_OUTPUT_RAW's motors."""
        s = self._ps[i] if self.scalar else self._phys
        k = 1.0 / self.airframe.omega_max
        if self.scalar:
            return (s.m0 * k, s.m1 * k, s.m2 * k, s.m3 * k)
        return (float(s.m0[i]) * k, float(s.m1[i]) * k, float(s.m2[i]) * k, float(s.m3[i]) * k)

    def controller_of(self, i: int) -> ccore.CopterCtrlState:
        """Vehicle i's controller memory as floats (read only): the position controller's
        target (px..az, yaw) and the attitude target (tan_roll_t, tan_pitch_t), for
        NAV_CONTROLLER_OUTPUT."""
        if self.scalar:
            return self._cs[i]
        out = ccore.CopterCtrlState(None)
        for f in ccore.CopterCtrlState.FIELDS:
            setattr(out, f, float(getattr(self._ctrl, f)[i]))
        return out

    @property
    def thrust_demand(self) -> np.ndarray:
        """Collective thrust fraction the controller asked for (0..1; 0 when idle)."""
        return np.where(np.array(self._run, dtype=bool), self.ctrl.coll, 0.0)

    def step(self, dt: float) -> None:
        """Controller (on the estimate) -> physics -> sensors -> estimator -> land detector."""
        if self.scalar:
            self._step_scalar(dt)
        else:
            self._step_vec(dt)

    def _step_vec(self, dt):
        g, xp = self.gains, NumpyOps
        est = self._est_view if self._est_view is not None else self._phys
        run = _copter_core(self._phys, self._ctrl, est, self.sp, self.armed, self._landed,
                           self.ground_z, g, self.airframe, dt, xp, self._air_vec())
        self.sim_time += dt
        self._est_view = self._sense_and_estimate_vec(dt)
        e = self._est_view if self._est_view is not None else self._phys
        self._landed, self._land_timer = _land_detect(self._ctrl, e, self._phys, run, self.armed, self._landed,
                                                      self._land_timer, g, dt, xp)
        self._run = run

    def _step_scalar(self, dt):
        gs, af, xp = self._gs, self.airframe, ScalarOps
        armed, landed, runs, timer = self._armed_l, self._landed, self._run, self._land_timer
        ps, cs, ss, ests = self._ps, self._cs, self._ss, self._ests
        for i in range(self.n):
            runs[i] = _copter_core(ps[i], cs[i], ests[i] or ps[i], ss[i], armed[i], landed[i],
                                   self._gz[i], gs[i], af, dt, xp, self._air_of(i))
        self.sim_time += dt
        self._sense_and_estimate_scalar(dt)
        for i in range(self.n):
            landed[i], timer[i] = _land_detect(cs[i], ests[i] or ps[i], ps[i], runs[i], armed[i], landed[i],
                                               timer[i], gs[i], dt, xp)


class RoverFleet(_FleetBase):
    """n skid-steer rovers (see vehicle.physics.rover). Same contract as CopterFleet;
    setpoint z is ignored and the rover stays at its home z. landed() is always True."""
    kind = "rover"
    STATE_FIELDS = rphys.RoverState.FIELDS

    def __init__(self, n: int, params: Mapping[str, float] | None = None, seed: int | Sequence[int] = 0,
                 home: np.ndarray | None = None, estimator: bool | str = True, model: rphys.RoverModel | None = None,
                 sensor_spec: SensorSpec | None = None, yaw: np.ndarray | float | None = None,
                 scalar: bool | None = None):
        self._init_common(n, params, seed, home, estimator, sensor_spec, scalar)
        self.model = model or rphys.RoverModel()
        self._make_gains()
        yaws = np.broadcast_to(np.asarray(0.0 if yaw is None else yaw, float), (self.n,))
        if self.scalar:
            self._ps = [rphys.RoverState(None, pos=self.home[i], yaw=float(yaws[i])) for i in range(self.n)]
            self._ss = [rcore.RoverSetpointArrays(None) for _ in range(self.n)]
        else:
            self._phys = rphys.RoverState(self.n, pos=self.home, yaw=yaws)
            self.sp = rcore.RoverSetpointArrays(self.n)
        for i in range(self.n):
            self.set_setpoint(i, Setpoint())

    def _new_gains(self, p):
        return rcore.RoverGains(p, self.model)

    def set_setpoint(self, i: int, sp: Setpoint) -> None:
        self.setpoints[i] = sp
        pos, vel, yaw, yaw_rate = _vec(sp.pos), _vec(sp.vel), _angle(sp.yaw), _angle(sp.yaw_rate)
        use_pos = pos is not None and bool(np.all(np.isfinite(pos[:2])))
        vel = np.zeros(3) if vel is None else np.nan_to_num(vel, posinf=0.0, neginf=0.0)
        vals = dict(px=float(pos[0]) if use_pos else 0.0, py=float(pos[1]) if use_pos else 0.0,
                    vx=float(vel[0]), vy=float(vel[1]), yaw=0.0 if yaw is None else yaw,
                    yaw_rate=0.0 if yaw_rate is None else yaw_rate)
        flags = dict(use_pos=use_pos, use_yaw=yaw is not None, use_yaw_rate=yaw_rate is not None, reached=False)
        if self.scalar:
            o = self._ss[i]
            for k, v in {**vals, **flags}.items():
                setattr(o, k, v)
        else:
            for k, v in {**vals, **flags}.items():
                getattr(self.sp, k)[i] = v

    def landed(self, i: int) -> bool:
        return True

    def drive_outputs(self, i: int) -> tuple[float, float, float]:
        """Vehicle i's drive: (commanded speed, speed, turn rate) in m/s, m/s and rad/s
        (positive turns right), for SERVO_OUTPUT_RAW and NAV_CONTROLLER_OUTPUT."""
        if self.scalar:
            s, sp = self._ps[i], self._ss[i]
            return (float(sp.v_cmd), float(s.speed), float(s.rate))
        return (float(self.sp.v_cmd[i]), float(self._phys.speed[i]), float(self._phys.rate[i]))

    def step(self, dt: float) -> None:
        """Controller (on the estimate) -> kinematics -> sensors -> estimator."""
        if self.scalar:
            xp, gs, m = ScalarOps, self._gs, self.model
            ps, ss, ests, armed = self._ps, self._ss, self._ests, self._armed_l
            for i in range(self.n):
                v, r = rcore.step(ests[i] or ps[i], ss[i], gs[i], dt, xp)
                if not armed[i]:
                    v = r = 0.0
                    ss[i].v_cmd = 0.0
                rphys.step(ps[i], v, r, m, gs[i], dt, xp, self._air_of(i))
            self.sim_time += dt
            self._sense_and_estimate_scalar(dt)
            return
        est = self._est_view if self._est_view is not None else self._phys
        v_cmd, r_cmd = rcore.step(est, self.sp, self.gains, dt)
        v_cmd = np.where(self.armed, v_cmd, 0.0)
        r_cmd = np.where(self.armed, r_cmd, 0.0)
        self.sp.v_cmd = np.where(self.armed, self.sp.v_cmd, 0.0)
        rphys.step(self._phys, v_cmd, r_cmd, self.model, self.gains, dt, air=self._air_vec())
        self.sim_time += dt
        self._est_view = self._sense_and_estimate_vec(dt)
