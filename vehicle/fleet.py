"""Batched vehicle groups the autopilot drives: CopterFleet and RoverFleet (pure, no I/O).

Each fleet steps all its vehicles together, one fixed step per ``step(dt)`` (400 Hz is
the design rate): controller (on the estimate) -> physics -> sensors -> estimator
(-> land detector). The autopilot maps modes and MAVLink commands to ``Setpoint``s; it
never touches physics. Truth (``truth(i)``, ``pos``...) is for scoring only; the
autopilot reads ``estimate(i)`` / ``est_pos`` etc. and ``estimate_ok(i)`` (pre-arm).

How modes use Setpoints (copter; all world NED, z down, ground at the vehicle's home z):
  hold / LOITER sticks centred / BRAKE: Setpoint()                velocity 0: brakes, holds
  position (GUIDED, AUTO, RTL legs): Setpoint(pos=p, yaw=psi)     jerk/accel/speed limited
                                     by WPNAV_SPEED(_UP/_DN), WPNAV_ACCEL(_Z), PSC_JERK_XY/Z
  follow / moving target:            Setpoint(pos=p, vel=v)       vel is feed-forward
  velocity (GUIDED velocity):        Setpoint(vel=v)              pos None (acc optional)
  takeoff:                           set_armed(i, True) + Setpoint(pos=(x, y, ground_z - alt))
  land:                              Setpoint(pos=(x, y, nan), vel=(0, 0, LAND_SPEED)),
                                     built by land_setpoint(i); NaN in pos = that axis
                                     group (xy or z) is velocity-controlled. landed(i) goes
                                     true ~1 s after touch-down; the autopilot then disarms.
  STABILIZE without RC input:        Setpoint(level=True)         roll/pitch level, altitude
                                     and yaw held, no horizontal control (drifts)
  attitude (GUIDED's attitude target, the pilot's lean angles in STABILIZE, ALT_HOLD, POSHOLD):
                                     Setpoint(roll=r, pitch=p, yaw=psi, vel=(0, 0, vz))
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

Injected faults (ArduPilot SITL's SIM_*, vehicle/sim_faults.py): set_faults(i, faults) gives
vehicle i's; a failed motor's output is multiplied in the step (a copter's rotor command, a
rover's left or right throttle), the sensor faults act in the sensors and the estimator.

Parameters are per vehicle (ArduPilot names): set_params(params, i) tunes vehicle i only,
set_params(params) all of them; params_of(i) / gains_of(i) read one vehicle's. The batched
step's self.gains holds floats where the vehicles agree and (n,) arrays where they differ.

Speed: fleets of n <= SCALAR_MAX step vehicle by vehicle on Python floats (the cores'
scalar forms, vehicle.physics.scalar_form, called directly; truth, gyro error and estimate
pass as Python rows, no numpy in the step but filterpy's) -- ~10 us per copter step on
truth, ~19 us with sensors and filterpy (tools/bench_flight.py); bigger fleets step as
numpy arrays (~0.5 us per drone-step at 1000). With estimator=True fleets above
BATCHED_KF_MIN use BatchedKF, filterpy's equations batched.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from vehicle.control import copter as ccore
from vehicle.control import rover as rcore
from vehicle.fleet_base import FleetBase, Setpoint, SoA, finite_angle, finite_or_zero, vec3
from vehicle.physics import NumpyOps, ScalarOps
from vehicle.physics import multicopter as mc
from vehicle.physics import rover as rphys
from vehicle.physics.scalar_form import generic
from vehicle.sensors import SensorSpec
from vehicle.sim_faults import skid_mix

MAX_LEAN = math.radians(80.0)   # an attitude target's roll and pitch are flown within this


def _attitude_values(sp: Setpoint, flags: dict) -> dict:
    """The controller's attitude-target values of `sp` (zeros, and flags att/use_thrust
    False, when it has no finite roll and pitch). A thrust target flies no vertical loop:
    its velocity target only tells the ground logic whether the copter wants up (ArduCopter
    takes off on a positive thrust)."""
    roll, pitch = finite_angle(sp.roll), finite_angle(sp.pitch)
    att = roll is not None and pitch is not None
    thrust = finite_angle(sp.thrust) if att else None
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


@generic
def _copter_core(ph, c, est, sp, armed, landed, ground_z, g, af, dt, xp, air=None, mul=None):
    """Controller + physics for one step (backend-generic). Returns the 'running' mask.
    mul: None, or the four motors' output multipliers (SIM_ENGINE_FAIL / SIM_ENGINE_MUL)."""
    climb = xp.where(sp.use_pos_z, sp.pz < ground_z - 0.25, sp.vz < -0.05)
    idle = landed & xp.lnot(climb)
    stop = idle | xp.lnot(armed)
    if xp.any(stop):
        ccore.relax(c, est, stop, xp)
    f = ccore.step(c, est, sp, g, dt, xp)
    om = af.omega_max
    run = armed & xp.lnot(idle)
    f0, f1, f2, f3 = f                  # (unrolled: a comprehension is a call of its own)
    if xp.all(run):
        cmd = (f0 * om, f1 * om, f2 * om, f3 * om)
    else:
        idle_w = xp.where(armed, om * g.spin_arm, 0.0)
        cmd = (xp.where(run, f0 * om, idle_w), xp.where(run, f1 * om, idle_w),
               xp.where(run, f2 * om, idle_w), xp.where(run, f3 * om, idle_w))
    if mul is not None:
        cmd = (cmd[0] * mul[0], cmd[1] * mul[1], cmd[2] * mul[2], cmd[3] * mul[3])
    mc.step(ph, cmd, af, dt, ground_z, xp, air)
    return run


@generic
def _rover_drive(est, sp, armed, g, dt, xp, mul=None):
    """Rover controller for one loop of dt s (backend-generic): the (speed m/s, turn rate
    rad/s) drive command the kinematics follow until the next loop; disarmed: no drive.
    mul: None, or the (left, right) drive multipliers of a skid-steer rover (SIM_ENGINE_FAIL)."""
    v, r = rcore.step(est, sp, g, dt, xp)
    v = xp.where(armed, v, 0.0)
    r = xp.where(armed, r, 0.0)
    sp.v_cmd = xp.where(armed, sp.v_cmd, 0.0)
    if mul is not None:
        v, r = skid_mix(v, r, mul[0], mul[1], g.max_speed, g.max_rate)
    return v, r


LAND_CHECK_ANGLE_ERROR = math.sin(math.radians(30.0) / 2) ** 2   # LAND_CHECK_ANGLE_ERROR_DEG, as att_err
LAND_DETECTOR_ACCEL_MAX = 1.0       # m/s^2, of the 1 Hz filtered acceleration (ArduCopter config.h)
LAND_DETECTOR_VEL_Z_MAX = 1.0       # m/s, the descent rate (ArduCopter config.h)
LAND_DETECTOR_ACCEL_LPF_CUTOFF = 1.0    # Hz
_ACCEL_RC = 1.0 / (2.0 * math.pi * LAND_DETECTOR_ACCEL_LPF_CUTOFF)   # s: ArduPilot's LowPassFilter RC
_ACCEL_MAX_SQ = LAND_DETECTOR_ACCEL_MAX * LAND_DETECTOR_ACCEL_MAX


@generic
def _land_detect(c, e, ph, run, armed, landed, timer, g, dt, xp):
    """ArduCopter's land detector (land_detector.cpp update_land_detector), on the estimate e
    (world NED): armed and, for LAND_DETECT_TIME (LAND_DETECTOR_TRIGGER_SEC), the motors at
    their lower limit (thrust demand under 0.8 hover) with the attitude controller's thrust
    error within LAND_CHECK_ANGLE_ERROR_DEG (its throttle-mix-min condition), the 1 Hz filtered
    acceleration within LAND_DETECTOR_ACCEL_MAX and the descent rate within
    LAND_DETECTOR_VEL_Z_MAX; no rangefinder is modelled, so none vetoes it. Horizontal speed
    plays no part (ArduCopter's does not look at it either). Cleared by a take-off (thrust
    demand near hover and those conditions gone). Disarmed: landed = resting on the ground.
    Keeps the filtered acceleration in c.lax, c.lay, c.laz every step."""
    k = dt / (dt + _ACCEL_RC)           # the low-pass coefficient (ArduPilot's LowPassFilter)
    ax = c.lax = c.lax + (e.ax - c.lax) * k
    ay = c.lay = c.lay + (e.ay - c.lay) * k
    az = c.laz = c.laz + (e.az - c.laz) * k
    coll = xp.where(run, c.coll, 0.0)
    low = (coll < 0.8 * g.hover) & (c.att_err <= LAND_CHECK_ANGLE_ERROR)
    still = ax * ax + ay * ay + az * az <= _ACCEL_MAX_SQ
    quiet = low & still & (xp.abs(e.vz) < LAND_DETECTOR_VEL_Z_MAX)
    timer = xp.where(armed & quiet, timer + dt, 0.0)
    took_off = run & (c.coll > 0.9 * g.hover) & xp.lnot(quiet)
    landed = xp.where(armed, (landed & xp.lnot(took_off)) | (timer >= g.land_time), ph.ground)
    return landed, timer


class CopterFleet(FleetBase):
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
            # the cores' scalar forms, called directly (vehicle.physics.scalar_form): no dispatch
            self._forms = (_copter_core.scalar(), _land_detect.scalar())
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
        return SoA(self._cs, ccore.CopterCtrlState.FIELDS) if self.scalar else self._ctrl

    def set_setpoint(self, i: int, sp: Setpoint) -> None:
        """Give vehicle i a new guidance target (see the module docstring for modes).
        pos components that are NaN leave that axis group (xy or z) velocity-controlled."""
        self.setpoints[i] = sp
        pos, vel, acc = vec3(sp.pos), vec3(sp.vel), vec3(sp.acc)
        yaw, yaw_rate = finite_angle(sp.yaw), finite_angle(sp.yaw_rate)
        vel = [0.0, 0.0, 0.0] if vel is None else finite_or_zero(vel)
        acc = [0.0, 0.0, 0.0] if acc is None else finite_or_zero(acc)
        if pos is None:
            use_xy = use_z = False
            pos = [0.0, 0.0, 0.0]
        else:
            use_xy = math.isfinite(pos[0]) and math.isfinite(pos[1])
            use_z = math.isfinite(pos[2])
            pos = finite_or_zero(pos)
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
        """On the ground: land detector when armed (~LAND_DETECT_TIME s of low thrust, small
        attitude error, no acceleration and little climb or descent: _land_detect), resting
        on the ground when disarmed."""
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
        mul = self._motor_mul
        if mul is not None:      # (4,) arrays over the fleet
            mul = [np.array([1.0 if m is None else m[k] for m in mul]) for k in range(4)]
        run = _copter_core(self._phys, self._ctrl, est, self.sp, self.armed, self._landed,
                           self.ground_z, g, self.airframe, dt, xp, self._air_vec(), mul)
        self.sim_time += dt
        self._est_view = self._sense_and_estimate_vec(dt)
        e = self._est_view if self._est_view is not None else self._phys
        self._landed, self._land_timer = _land_detect(self._ctrl, e, self._phys, run, self.armed, self._landed,
                                                      self._land_timer, g, dt, xp)
        self._run = run

    def _step_scalar(self, dt):
        core, land = self._forms
        gs, af, xp = self._gs, self.airframe, ScalarOps
        armed, landed, runs, timer = self._armed_l, self._landed, self._run, self._land_timer
        ps, cs, ss, ests, gz, air = self._ps, self._cs, self._ss, self._ests, self._gz, self._air_rows
        muls = self._motor_mul                  # None (no motor fault anywhere): nothing built per step
        for i in range(self.n):
            runs[i] = core(ps[i], cs[i], ests[i] or ps[i], ss[i], armed[i], landed[i], gz[i], gs[i], af, dt, xp,
                           None if air is None else air[i], None if muls is None else muls[i])
        self.sim_time += dt
        self._sense_and_estimate_scalar(dt)
        for i in range(self.n):
            landed[i], timer[i] = land(cs[i], ests[i] or ps[i], ps[i], runs[i], armed[i], landed[i],
                                       timer[i], gs[i], dt, xp)


class RoverFleet(FleetBase):
    """n skid-steer rovers (see vehicle.physics.rover). Same contract as CopterFleet;
    setpoint z is ignored and the rover stays at its home z. landed() is always True.

    loop_every: the controller, sensors and estimator run once every loop_every steps (over
    that loop's time), the kinematics every step holding the loop's drive command; 1 (the
    default) runs all of it every step. The world gives its rovers ArduRover's 50 Hz loop
    (vehicle.world_build.ROVER_LOOP_RATE)."""
    kind = "rover"
    STATE_FIELDS = rphys.RoverState.FIELDS

    def __init__(self, n: int, params: Mapping[str, float] | None = None, seed: int | Sequence[int] = 0,
                 home: np.ndarray | None = None, estimator: bool | str = True, model: rphys.RoverModel | None = None,
                 sensor_spec: SensorSpec | None = None, yaw: np.ndarray | float | None = None,
                 scalar: bool | None = None, loop_every: int = 1):
        self._init_common(n, params, seed, home, estimator, sensor_spec, scalar)
        self.model = model or rphys.RoverModel()
        # the controller, sensors and estimator run every loop_every steps (the rover's loop
        # rate), the kinematics every step; the world runs them at ArduRover's 50 Hz
        self.loop_every = max(1, int(loop_every))
        self._loop_k = 0                         # steps into the current loop
        self._cmds = [(0.0, 0.0)] * self.n       # the scalar store's drive commands of the loop
        self._cmd_vec = None                     # the vector store's: (speed, rate) arrays
        if self.scalar:     # the cores' scalar forms, called directly (vehicle.physics.scalar_form)
            self._drive_form = _rover_drive.scalar()
            self._kinematics_form = rphys.step.scalar()
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
        pos, vel, yaw, yaw_rate = vec3(sp.pos), vec3(sp.vel), finite_angle(sp.yaw), finite_angle(sp.yaw_rate)
        use_pos = pos is not None and math.isfinite(pos[0]) and math.isfinite(pos[1])
        vel = [0.0, 0.0, 0.0] if vel is None else finite_or_zero(vel)
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

    def turn_command(self, i: int) -> float:
        """The turn rate (rad/s, positive right) vehicle i's steering asked for at its last
        step (PID_TUNING's steering target)."""
        return float(self._ss[i].r_cmd if self.scalar else self.sp.r_cmd[i])

    def step(self, dt: float) -> None:
        """Controller (on the estimate, at the first step of a loop) -> kinematics (every
        step) -> sensors -> estimator (at the last step of a loop, over the loop's time)."""
        k = self._loop_k
        last = k + 1 >= self.loop_every
        self._loop_k = 0 if last else k + 1
        ldt = dt * self.loop_every              # the loop's time (dt itself when every step is one)
        m = self.model
        if self.scalar:
            xp, gs, ps, air, cmds = ScalarOps, self._gs, self._ps, self._air_rows, self._cmds
            if k == 0:
                drive, ss, ests, armed = self._drive_form, self._ss, self._ests, self._armed_l
                muls = self._motor_mul          # None (no motor fault anywhere): nothing built per step
                for i in range(self.n):
                    mul = None if muls is None or muls[i] is None else (muls[i][0], muls[i][2])   # left, right
                    cmds[i] = drive(ests[i] or ps[i], ss[i], armed[i], gs[i], ldt, xp, mul)
            kinematics = self._kinematics_form
            for i in range(self.n):
                v, r = cmds[i]
                kinematics(ps[i], v, r, m, gs[i], dt, xp, None if air is None else air[i])
            self.sim_time += dt
            if last:
                self._sense_and_estimate_scalar(ldt)
            return
        if k == 0:
            est = self._est_view if self._est_view is not None else self._phys
            mul = None
            if self._motor_mul is not None:      # SIM_ENGINE_FAIL: servo 1 left, servo 3 right
                mul = tuple(np.array([1.0 if f is None else f[j] for f in self._motor_mul]) for j in (0, 2))
            self._cmd_vec = _rover_drive(est, self.sp, self.armed, self.gains, ldt, NumpyOps, mul)
        v, r = self._cmd_vec
        rphys.step(self._phys, v, r, m, self.gains, dt, NumpyOps, self._air_vec())
        self.sim_time += dt
        if last:
            self._est_view = self._sense_and_estimate_vec(ldt)
