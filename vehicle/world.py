"""The SITL world: one sim clock, batched fleets, per-vehicle autopilots and MAVLink links,
all stepped in lockstep on one asyncio event loop.

Wind: one air mass per world (vehicle/physics/wind.py, ArduPilot's SIM_WIND_*), from
WorldConfig.wind (`towerlink sitl --wind`, a scenario's wind table) or else vehicle 0's
SIM_WIND_* parameters; every vehicle's SIM_WIND_* show it and a PARAM_SET of one on any
vehicle changes it. Turbulence is seeded by the world's seed. The fleets get their air
velocity at the autopilot rate.

Time: physics advances in fixed steps of 1/rate sim seconds; autopilots and telemetry run
every `ap_every` steps (50 Hz), and so do a rover's controller, sensors and estimator
(ArduRover's 50 Hz loop; a copter's run every step, as ArduCopter's 400 Hz loop). With `speedup` N the world tracks N sim seconds per wall
second; when the CPU cannot keep up it runs slower (re-anchoring its wall reference), never
skipping or stretching a step. All MAVLink time fields are this sim time. `speedup`
inf (`--speedup max`) does not pace at all.

Lockstep (`lockstep` N > 0, off by default): the world waits at t = 0 for N
participants (TOWERLINK_LOCKSTEP JOIN on every vehicle), then at every lockstep frame sends
TICK(t) after everything it sent up to t and does not step on until every participant ACKed
t (vehicle/lockstep.py). Participants' packets arriving between TICKs are held to the next
TICK boundary, so they take effect at a sim time fixed by the data they react to. Pipelined
(`lockstep_pipeline`): TICK(t) goes out and the world steps on at once, waiting for ACK(t) at
the next TICK; reactions to TICK(t) take effect there, one period later.

Python API (tests, tools):
    w = World(WorldConfig(drones=1, rovers=1, endpoints={0: ["udpin:127.0.0.1:14560"]}))
    w.start_thread(); ...; w.stop()          # or: asyncio.run(w.run())
    w.vehicles[0].ap, w.vehicles[0].link.stats, w.t
"""
from __future__ import annotations

import asyncio
import json
import math
import os
import threading
import time

from vehicle.autopilot.params import ParamStore
from vehicle.link.outbox import Outbox
from vehicle.logs.world_logs import WorldLogs
from vehicle.loop_cpu import LoopCpu
from vehicle.physics.wind import WindField, WindParams
from vehicle.world_build import Vehicle, build, start_position
from vehicle.world_config import DEFAULT_HOME, WorldConfig
from vehicle.world_lockstep import WorldLockstep

__all__ = ["DEFAULT_HOME", "Vehicle", "World", "WorldConfig"]     # what the world's users import here

AP_RATE = 50.0
SHARE_RATE = 10.0        # Hz sim: GLOBAL_POSITION_INT heard by the other vehicles (FOLLOW)


class World:
    def __init__(self, cfg: WorldConfig) -> None:
        if cfg.rate <= 0 or cfg.speedup <= 0:
            raise ValueError("rate and speedup must be positive")
        self.cfg = cfg
        self.dt = 1.0 / cfg.rate
        self.ap_every = max(1, int(round(cfg.rate / AP_RATE)))
        self.share_every = self.ap_every * max(1, int(round(AP_RATE / SHARE_RATE)))
        self.steps = 0
        self.t = 0.0
        # sim t = 0 is this wall time (--workers: one instant shared by every process)
        self.start_at = cfg.start_at if cfg.start_at is not None else time.time()
        self.unix_start_us = int(self.start_at * 1e6)
        self.vehicles: list[Vehicle] = []
        self.plan = cfg.network_plan()        # PlanError before anything is built
        # one air mass for the world (SIM_WIND_*), turbulence seeded by the world's seed
        self.wind = WindField(cfg.wind, cfg.seed)
        lo, hi = cfg.share_range()
        self.lockstep = (WorldLockstep(self, hi - lo, cfg.lockstep, cfg.lockstep_period, cfg.lockstep_timeout,
                                       lag=1 if cfg.lockstep_pipeline else 0)
                         if cfg.lockstep > 0 else None)
        self.logs = WorldLogs()          # the onboard logs' writer thread (vehicle/logs/)
        self.outbox = Outbox()           # the endpoints' writes, held while a chunk is stepped
        self.loop_cpu = LoopCpu()         # the stepping loop's CPU, for the stats (vehicle/loop_cpu.py)
        built = build(cfg, self.plan, self.clock, self.unix_start_us, self._wind_set,
                      self.lockstep.intake if self.lockstep is not None else lambda index: None, self.logs,
                      self.outbox)
        self.fleets: list[tuple[str, object]] = built.fleets
        self.vehicles = built.vehicles
        self._fleet_ids = built.fleet_ids
        # a saved SYSID_THISMAV (a PARAM_SET before a restart) wins over the plan's: refuse a
        # clash (with --workers, among this process's vehicles and the others' planned sysids)
        booted = [v.sysid for v in self.plan.vehicles]
        for v in self.vehicles:
            booted[v.index] = v.sysid
        self.plan = self.plan.with_sysids(booted)
        self._init_wind()
        self._stop: asyncio.Event | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self.ready = threading.Event()
        self.behind_events = 0

    start_position = staticmethod(start_position)

    # ----- wind ---------------------------------------------------------------------------
    def _wind_set(self, store: ParamStore) -> None:
        """A vehicle's SIM_WIND_* were set (PARAM_SET): the world's air follows them."""
        if self.vehicles:               # (not while the vehicles are being built)
            self.set_wind(WindParams.from_params(store.values))

    def _init_wind(self) -> None:
        if self.cfg.wind is not None:
            self.set_wind(self.cfg.wind)
        elif self.vehicles:
            self.set_wind(WindParams.from_params(self.vehicles[0].ap.params.values))

    def set_wind(self, params: WindParams) -> None:
        """The world's wind from now on (the air follows within wind.SMOOTH_TAU); every
        vehicle's SIM_WIND_* show it (not saved: the world's option, not the vehicle's)."""
        self.wind.set(params)
        for v in self.vehicles:
            store = v.ap.params
            for name, value in params.as_params().items():
                if name in store and store.get(name) != value:
                    store.set(name, value, save=False)

    def _update_air(self) -> None:
        """Each fleet's air velocity for the next autopilot period (50 Hz is plenty for a
        wind whose turbulence has a 0.5 s correlation time)."""
        w = self.wind
        if not w.active:
            for _, fleet in self.fleets:
                if fleet.air is not None:
                    fleet.set_air(None)
            return
        dt = self.dt * self.ap_every
        w.advance(dt)
        for kind, fleet in self.fleets:
            h = fleet.home[:, 2] - fleet.pos[:, 2]        # height above its home ground, m
            fleet.set_air(w.air_velocity(kind, h, h > 0.05, dt, self._fleet_ids[kind]))

    def clock(self) -> float:
        return self.t

    def share_positions(self, t: float) -> None:
        """The vehicles of one world hear each other's GLOBAL_POSITION_INT, as vehicles on one
        telemetry network do (ArduPilot routes it between its links; a mavlink-router or a
        shared radio does between vehicles). Only a vehicle with FOLL_ENABLE listens: it is
        FOLLOW's lead. Vehicles in other processes get it over MAVLink (on_GLOBAL_POSITION_INT)."""
        listeners = [v for v in self.vehicles if v.ap.follow.enabled()]
        if not listeners:
            return
        for lead in self.vehicles:
            if not lead.ap.est_ok:
                continue
            msg = lead.link.telemetry.global_position_int()
            for v in listeners:
                if v is not lead:
                    v.ap.follow.on_global_position(lead.sysid, msg, t, v.ap.home_lla()[2])

    def log(self, text: str) -> None:
        print(f"[sitl t={self.t:9.3f}] {text}", flush=True)

    # ----- stepping ---------------------------------------------------------------------
    def step(self) -> None:
        dt = self.dt
        if self.steps % self.ap_every == 0:
            self._update_air()
        for _, fleet in self.fleets:
            fleet.step(dt)
        self.steps += 1
        self.t = self.steps * dt
        if self.steps % self.ap_every == 0:
            t = self.t
            for v in self.vehicles:
                v.ap.update(t)
                v.link.update(t)
            if self.steps % self.share_every == 0:
                self.share_positions(t)

    def run_for(self, seconds: float) -> None:
        """Step synchronously (no I/O pacing) for `seconds` of sim time."""
        end = self.steps + int(round(seconds / self.dt))
        while self.steps < end:
            self.step()

    # ----- the event loop ---------------------------------------------------------------
    async def start_endpoints(self) -> None:
        for v in self.vehicles:
            await v.link.start()

    async def run(self, started=None) -> None:
        """Open the endpoints, step until request_stop(), close them (also when an endpoint
        cannot be opened: the ones already open are closed before the OSError goes on)."""
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        try:
            await self.start_endpoints()
            for v in self.vehicles:
                v.ap.update(self.t)
            if started is not None:
                started()
            self.ready.set()
            await self._lockstep()
        finally:
            for v in self.vehicles:
                v.link.close()
            self.logs.close()           # the logs' last bytes written (the links closed them)
            await asyncio.sleep(0)      # closed connections end while the loop still runs

    async def _lockstep(self) -> None:
        lock = self.lockstep
        frame = 0 if lock is None else lock.frame_steps
        if lock is not None:
            await lock.start(self._stop)
        wall0, sim0 = time.monotonic(), self.t
        if self.cfg.start_at is not None and self.steps == 0 and lock is None:
            # (with lockstep the participants' JOINs are the shared start, not a wall instant)
            # a shared start: every worker's sim t = 0 is the same wall instant
            wall0 += self.cfg.start_at - time.time()
            await asyncio.sleep(max(0.0, wall0 - time.monotonic()))
        self.loop_cpu.start(self.steps)
        try:
            await self._step_until_stopped(lock, frame, wall0, sim0)
        finally:
            self.loop_cpu.stop(self.steps)

    async def _step_until_stopped(self, lock, frame: int, wall0: float, sim0: float) -> None:
        """Step in chunks (paced, or as fast as the CPU and the lockstep allow), serving I/O
        between them, until request_stop()."""
        speedup, dt = self.cfg.speedup, self.dt
        cpu, clock = self.loop_cpu, time.thread_time
        paced = math.isfinite(speedup)     # --speedup max: as fast as the CPU (and the gate) allow
        chunk = 0.02                   # wall seconds of stepping before yielding to I/O
        min_sleep = 0.004              # fewer, larger sleeps: steps bunch up, sim time does not care
        max_lag = max(0.1 * speedup, 4 * dt) if paced else math.inf
        while not self._stop.is_set():
            now = time.monotonic()
            target = sim0 + speedup * (now - wall0) if paced else math.inf
            if paced and target - self.t > max_lag:
                # the CPU cannot keep up: forget the backlog beyond max_lag, so the world runs
                # slower than asked, never skipping or stretching a step, and never bursting
                self.behind_events += 1
                wall0 = now - (self.t + max_lag - sim0) / speedup
                target = self.t + max_lag
            deadline = now + chunk
            n = 0
            blocked = False
            self.outbox.cork()                  # written below, before any wait (vehicle/link/outbox.py)
            c0 = clock()
            while self.t + 0.5 * dt <= target:
                # (between TICK boundaries there is nothing to ask the lockstep)
                if frame and self.steps % frame == 0:
                    b0 = clock()
                    blocked = lock.boundary()   # at a TICK not every participant ACKed yet
                    c0 += clock() - b0          # (the boundary's TICKs are not stepping)
                    if blocked:
                        break
                self.step()
                n += 1
                if (n & 3) == 0 and time.monotonic() > deadline:
                    break
            cpu.stepping += clock() - c0
            self.outbox.flush()                 # the chunk's telemetry, then its TICKs, in order
            if blocked:
                await lock.wait(self._stop)
                continue
            if not paced or self.t + 0.5 * dt <= target:
                await asyncio.sleep(0)          # behind: serve I/O, then keep stepping
                continue
            next_wall = wall0 + (self.t + dt - sim0) / speedup
            await asyncio.sleep(max(min_sleep, next_wall - time.monotonic()))

    def request_stop(self) -> None:
        if self._loop is not None and self._stop is not None:
            try:
                self._loop.call_soon_threadsafe(self._stop.set)
            except RuntimeError:        # the loop has already ended: nothing left to stop
                pass

    # ----- background thread (tests) ------------------------------------------------------
    def start_thread(self, timeout: float = 10.0) -> "World":
        self._thread = threading.Thread(target=lambda: asyncio.run(self.run()), name="towerlink-world",
                                        daemon=True)
        self._thread.start()
        if not self.ready.wait(timeout):
            raise RuntimeError("world did not start")
        return self

    def stop(self, timeout: float = 10.0) -> None:
        self.request_stop()
        if self._thread is not None:
            self._thread.join(timeout)

    def write_plan(self, path: str) -> None:
        """The network plan as JSON (vehicle index, kind, network, sysid, tcp, udp, endpoints),
        written atomically (tmp file, then os.replace) so a reader never sees half of it."""
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        tmp = f"{path}.tmp{os.getpid()}"
        with open(tmp, "w") as f:
            json.dump(self.plan.as_dict(), f, indent=1)
        os.replace(tmp, path)

    def banner(self, workers: int = 1) -> str:
        """What `towerlink sitl` prints at start: the world, its networks, every vehicle
        (from the plan, so a process running a share of the world prints all of them)."""
        p = self.plan
        lines = [f"towerlink sitl: {len(p.vehicles)} vehicle(s), home {self.cfg.home[0]:.6f},"
                 f"{self.cfg.home[1]:.6f},{self.cfg.home[2]:.1f}, rate {self.cfg.rate:g} Hz, "
                 f"speedup {self.cfg.speedup:g}, seed {self.cfg.seed}"
                 + (f", {workers} worker processes" if workers > 1 else "")
                 + (f", lockstep with {self.cfg.lockstep} participant(s)" if self.cfg.lockstep else "")
                 + (" pipelined (reactions take effect one TICK later)"
                    if self.cfg.lockstep and self.cfg.lockstep_pipeline else "")]
        if len(p.groups) > 1 or p.stride != 10:
            lines.append(f"{len(p.groups)} MAVLink network(s) of up to {p.group_size} vehicles, "
                         f"ports every {p.stride}:")
            lines += p.summary()
        for v in p.vehicles:
            name = "drone" if v.kind == "copter" else "rover"
            net = f" network {v.group}" if len(p.groups) > 1 else ""
            lines.append(f"  vehicle {v.index}: {name}{net} sysid {v.sysid} ({'QUADROTOR' if v.kind == 'copter' else 'GROUND_ROVER'})"
                         f"  {'  '.join(v.endpoints)}")
        return "\n".join(lines)

    def set_start(self, start_at: float) -> None:
        """Sim t = 0 at this unix time (--workers: the instant the parent hands out)."""
        self.cfg.start_at = self.start_at = start_at
        self.unix_start_us = int(start_at * 1e6)
        for v in self.vehicles:
            v.link.telemetry.set_unix_start(self.unix_start_us)
            v.link.logs.set_unix_start(self.unix_start_us)

    def stats_line(self) -> str:
        parts = []
        for v in self.vehicles:
            s = v.link.stats
            who = f"vehicle {v.index} sysid {v.sysid}" if len(self.plan.groups) > 1 else f"sysid {v.sysid}"
            parts.append(f"{who}: " + " ".join(f"{k}={s[k]}" for k in sorted(s)))
        line = "stats: " + "; ".join(parts)
        if self.lockstep is not None:
            line += "\n" + self.lockstep.stats_line()
        if self.loop_cpu.steps:
            line += "\n" + self.loop_cpu.line()
        return line
