"""Batched vehicle groups the autopilot drives: CopterFleet and RoverFleet (pure, no I/O).

Each fleet steps all its vehicles together as numpy arrays: physics -> sensors ->
estimator -> controller, one fixed step per ``step(dt)``. The autopilot maps modes and
MAVLink commands to ``Setpoint``s; it never touches physics.

How modes use Setpoints (copter):
  hold / LOITER-without-RC / BRAKE:   Setpoint()                     (velocity 0: brakes, holds)
  position (GUIDED, AUTO, RTL legs):  Setpoint(pos=p, yaw=...)       (jerk/accel/speed limited)
  follow / moving target:             Setpoint(pos=p, vel=v_target)  (vel is feed-forward)
  velocity (GUIDED velocity):         Setpoint(vel=v)                (pos None)
  takeoff:                            armed + Setpoint(pos=(x, y, ground - alt))
  land:                               Setpoint(pos=(x, y, nan), vel=(0, 0, LAND_SPEED))
                                      (NaN in pos = that axis is velocity-controlled);
                                      ``CopterFleet.land_setpoint(i)`` builds it; then
                                      ``landed(i)`` goes true and the autopilot disarms.
  STABILIZE without RC:               Setpoint(level=True)           (roll/pitch level,
                                      altitude held, yaw held; horizontal drift free)
An armed copter on the ground idles (MOT_SPIN_ARM) until its setpoint is above ground
(position z more than 0.25 m above ground, or a climb velocity). Disarmed: motors stop.

Rover: Setpoint(pos=p) drive there and stop (WP_RADIUS); Setpoint(pos=p, vel=v) follow a
moving target; Setpoint(vel=v) drive at a velocity; Setpoint() hold (stop); yaw turns in
place when stopped. z is ignored.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from vehicle import params_core
from vehicle.control import copter as ccore
from vehicle.control import rover as rcore
from vehicle.estimation import Estimator, quat_to_R
from vehicle.physics import NumpyOps
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
        x, y, z, w = self.quat
        return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))

    @property
    def euler(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) rad, ZYX."""
        x, y, z, w = self.quat
        roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
        return roll, pitch, self.yaw


def _vec(v) -> np.ndarray | None:
    return None if v is None else np.asarray(v, dtype=float).reshape(3)


class _Est:
    """Component view of estimator arrays for the controller."""

    def __init__(self, pos, vel, quat, rates):
        self.px, self.py, self.pz = pos[:, 0], pos[:, 1], pos[:, 2]
        self.vx, self.vy, self.vz = vel[:, 0], vel[:, 1], vel[:, 2]
        self.qx, self.qy, self.qz, self.qw = quat[:, 0], quat[:, 1], quat[:, 2], quat[:, 3]
        self.wx, self.wy, self.wz = rates[:, 0], rates[:, 1], rates[:, 2]


class _FleetBase:
    kind = "copter"

    def _init_common(self, n, params, seed, home, estimator, sensor_spec):
        self.n = int(n)
        self.home = np.zeros((self.n, 3)) if home is None else np.array(home, float).reshape(self.n, 3)
        self.params = params_core.merged(self.kind, params)
        self.sim_time = 0.0
        self.armed = np.zeros(self.n, dtype=bool)
        self.use_estimator = bool(estimator)
        self.spec = sensor_spec or SensorSpec()
        if self.use_estimator:
            rngs = vehicle_rngs(seed, self.n)
            self.sensors = Sensors(rngs, self.spec)
            self.estimator = Estimator(self.n, self.home, self.spec)
        self.setpoints: list[Setpoint] = [Setpoint() for _ in range(self.n)]

    # ---- batched arrays (n,3)/(n,4) ----------------------------------------------
    @property
    def pos(self) -> np.ndarray:
        s = self.phys
        return np.column_stack((s.px, s.py, s.pz))

    @property
    def vel(self) -> np.ndarray:
        s = self.phys
        return np.column_stack((s.vx, s.vy, s.vz))

    @property
    def quat(self) -> np.ndarray:
        s = self.phys
        return np.column_stack((s.qx, s.qy, s.qz, s.qw))

    @property
    def rates(self) -> np.ndarray:
        s = self.phys
        return np.column_stack((s.wx, s.wy, s.wz))

    @property
    def acc(self) -> np.ndarray:
        s = self.phys
        return np.column_stack((s.ax, s.ay, s.az))

    @property
    def est_pos(self) -> np.ndarray:
        return self.estimator.pos.copy() if self.use_estimator else self.pos

    @property
    def est_vel(self) -> np.ndarray:
        return self.estimator.vel.copy() if self.use_estimator else self.vel

    @property
    def est_quat(self) -> np.ndarray:
        return self.estimator.quat.copy() if self.use_estimator else self.quat

    @property
    def est_rates(self) -> np.ndarray:
        return self.estimator.rates.copy() if self.use_estimator else self.rates

    @property
    def est_acc(self) -> np.ndarray:
        return self.estimator.acc.copy() if self.use_estimator else self.acc

    @property
    def est_yaw(self) -> np.ndarray:
        q = self.est_quat
        return np.arctan2(2 * (q[:, 3] * q[:, 2] + q[:, 0] * q[:, 1]), 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2))

    def truth(self, i: int) -> VehicleState:
        """True state of vehicle i (for scoring; the autopilot uses estimate())."""
        s = self.phys
        return VehicleState(np.array([s.px[i], s.py[i], s.pz[i]]), np.array([s.vx[i], s.vy[i], s.vz[i]]),
                            np.array([s.qx[i], s.qy[i], s.qz[i], s.qw[i]]),
                            np.array([s.wx[i], s.wy[i], s.wz[i]]), np.array([s.ax[i], s.ay[i], s.az[i]]),
                            self.sim_time)

    def estimate(self, i: int) -> VehicleState:
        """What the autopilot believes about vehicle i."""
        if not self.use_estimator:
            return self.truth(i)
        e = self.estimator
        return VehicleState(e.pos[i].copy(), e.vel[i].copy(), e.quat[i].copy(), e.rates[i].copy(),
                            e.acc[i].copy(), self.sim_time)

    def estimate_ok(self, i: int) -> bool:
        return True if not self.use_estimator else bool(self.estimator.ok[i])

    def set_armed(self, i: int, armed: bool) -> None:
        self.armed[i] = bool(armed)

    def setpoint(self, i: int) -> Setpoint:
        """The last Setpoint given to vehicle i."""
        return self.setpoints[i]

    def _sense_and_estimate(self, dt):
        if not self.use_estimator:
            return None
        R = quat_to_R(self.quat)
        self.sensors.sample(self.sim_time, self.pos, self.vel, self.acc, R, self.rates)
        self.estimator.update(self.sim_time, dt, self.sensors, self.quat)
        e = self.estimator
        return _Est(e.pos, e.vel, e.quat, e.rates)


class CopterFleet(_FleetBase):
    """n quad-X copters. params: ArduPilot names (vehicle.params_core.COPTER_PARAMS).

    seed: int (vehicle i seeded with [seed, i]) or a sequence of per-vehicle seeds.
    home: (n,3) world NED start positions; each vehicle's ground is at its home z.
    estimator=False flies on truth with no sensor noise (the 1000-drone benchmark)."""
    kind = "copter"

    def __init__(self, n: int, params: Mapping[str, float] | None = None, seed: int | Sequence[int] = 0,
                 home: np.ndarray | None = None, estimator: bool = True, airframe: mc.QuadAirframe | None = None,
                 sensor_spec: SensorSpec | None = None, yaw: np.ndarray | float | None = None):
        self._init_common(n, params, seed, home, estimator, sensor_spec)
        self.airframe = airframe or mc.QuadAirframe()
        self.ground_z = self.home[:, 2].copy()
        self.phys = mc.QuadState(self.n, pos=self.home, yaw=yaw)
        self.ctrl = ccore.CopterCtrlState(self.n)
        self.sp = ccore.SetpointArrays(self.n)
        self.gains = ccore.CopterGains(self.params)
        self._landed = np.ones(self.n, dtype=bool)
        self._land_timer = np.zeros(self.n)
        ccore.relax(self.ctrl, self.phys, np.ones(self.n, dtype=bool))
        for i in range(self.n):
            self.set_setpoint(i, Setpoint())

    def set_params(self, params: Mapping[str, float]) -> None:
        for k, v in params.items():
            if k in self.params:
                self.params[k] = float(v)
        self.gains = ccore.CopterGains(self.params)

    def set_setpoint(self, i: int, sp: Setpoint) -> None:
        self.setpoints[i] = sp
        a = self.sp
        pos, vel, acc = _vec(sp.pos), _vec(sp.vel), _vec(sp.acc)
        vel = np.zeros(3) if vel is None else np.nan_to_num(vel)
        acc = np.zeros(3) if acc is None else np.nan_to_num(acc)
        if pos is None:
            use_xy = use_z = False
            pos = np.zeros(3)
        else:
            use_xy = bool(np.isfinite(pos[0]) and np.isfinite(pos[1]))
            use_z = bool(np.isfinite(pos[2]))
            pos = np.nan_to_num(pos)
        a.px[i], a.py[i], a.pz[i] = pos
        a.vx[i], a.vy[i], a.vz[i] = vel
        a.ax[i], a.ay[i], a.az[i] = acc
        a.use_pos_xy[i], a.use_pos_z[i] = use_xy, use_z
        a.level[i] = bool(sp.level)
        a.use_yaw[i] = sp.yaw is not None
        a.yaw[i] = 0.0 if sp.yaw is None else float(sp.yaw)
        a.yaw_rate[i] = 0.0 if sp.yaw_rate is None else float(sp.yaw_rate)

    def land_setpoint(self, i: int, xy: Sequence[float] | None = None) -> Setpoint:
        """Descend at LAND_SPEED over xy (default: where the estimate is)."""
        if xy is None:
            xy = self.estimate(i).pos[:2]
        return Setpoint(pos=np.array([xy[0], xy[1], np.nan]), vel=np.array([0.0, 0.0, self.gains.land_speed]))

    def landed(self, i: int) -> bool:
        return bool(self._landed[i])

    @property
    def landed_mask(self) -> np.ndarray:
        return self._landed.copy()

    @property
    def thrust_demand(self) -> np.ndarray:
        """Collective thrust fraction the controller asked for (0..1)."""
        return np.asarray(self.ctrl.coll, float).copy()

    def step(self, dt: float) -> None:
        g = self.gains
        est = self._est_view
        if est is None:
            est = self.phys
        sp = self.sp
        climb = np.where(sp.use_pos_z, sp.pz < self.ground_z - 0.25, sp.vz < -0.05)
        idle = self._landed & ~climb
        ccore.relax(self.ctrl, est, idle | ~self.armed)
        f = ccore.step(self.ctrl, est, sp, g, dt)
        om = self.airframe.omega_max
        idle_w = np.where(self.armed, om * g.spin_arm, 0.0)
        run = self.armed & ~idle
        cmd = [np.where(run, fi * om, idle_w) for fi in f]
        mc.step(self.phys, cmd, self.airframe, dt, self.ground_z)
        self.sim_time += dt
        self._est_view = self._sense_and_estimate(dt)
        # land detector (ArduPilot idea): low thrust demand, not moving, for LAND_DETECT_TIME
        e = self._est_view if self._est_view is not None else self.phys
        coll = np.where(run, self.ctrl.coll, 0.0)
        quiet = (coll < 0.8 * g.hover) & (np.abs(e.vz) < 0.3) & (np.hypot(e.vx, e.vy) < 1.0)
        self._land_timer = np.where(self.armed & quiet, self._land_timer + dt, 0.0)
        took_off = run & (self.ctrl.coll > 0.9 * g.hover) & ~quiet
        landed = np.where(self.armed, (self._landed & ~took_off) | (self._land_timer >= g.land_time),
                          self.phys.ground)
        self._landed = landed

    _est_view = None


class RoverFleet(_FleetBase):
    """n skid-steer rovers (see vehicle.physics.rover). Same contract as CopterFleet;
    setpoint z is ignored and the rover stays at its home z."""
    kind = "rover"

    def __init__(self, n: int, params: Mapping[str, float] | None = None, seed: int | Sequence[int] = 0,
                 home: np.ndarray | None = None, estimator: bool = True, model: rphys.RoverModel | None = None,
                 sensor_spec: SensorSpec | None = None, yaw: np.ndarray | float | None = None):
        self._init_common(n, params, seed, home, estimator, sensor_spec)
        self.model = model or rphys.RoverModel()
        self.phys = rphys.RoverState(self.n, pos=self.home, yaw=yaw)
        self.gains = rcore.RoverGains(self.params, self.model)
        self.sp = rcore.RoverSetpointArrays(self.n)
        for i in range(self.n):
            self.set_setpoint(i, Setpoint())

    def set_params(self, params: Mapping[str, float]) -> None:
        for k, v in params.items():
            if k in self.params:
                self.params[k] = float(v)
        self.gains = rcore.RoverGains(self.params, self.model)

    def set_setpoint(self, i: int, sp: Setpoint) -> None:
        self.setpoints[i] = sp
        a = self.sp
        pos, vel = _vec(sp.pos), _vec(sp.vel)
        a.use_pos[i] = pos is not None and bool(np.all(np.isfinite(pos[:2])))
        a.px[i], a.py[i] = (pos[0], pos[1]) if a.use_pos[i] else (0.0, 0.0)
        a.vx[i], a.vy[i] = (0.0, 0.0) if vel is None else np.nan_to_num(vel[:2])
        a.use_yaw[i] = sp.yaw is not None
        a.yaw[i] = 0.0 if sp.yaw is None else float(sp.yaw)

    def landed(self, i: int) -> bool:
        return True

    def step(self, dt: float) -> None:
        est = self._est_view
        if est is None:
            est = self.phys
        v_cmd, r_cmd = rcore.step(est, self.sp, self.gains, dt)
        v_cmd = np.where(self.armed, v_cmd, 0.0)
        r_cmd = np.where(self.armed, r_cmd, 0.0)
        rphys.step(self.phys, v_cmd, r_cmd, self.model, self.gains, dt)
        self.sim_time += dt
        self._est_view = self._sense_and_estimate(dt)

    _est_view = None
