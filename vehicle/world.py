"""The SITL world: one sim clock, batched fleets, per-vehicle autopilots and MAVLink links,
all stepped in lockstep on one asyncio event loop.

Time: physics advances in fixed steps of 1/rate sim seconds; autopilots and telemetry run
every `ap_every` steps (50 Hz). With `speedup` N the world tracks N sim seconds per wall
second; when the CPU cannot keep up it runs slower (re-anchoring its wall reference), never
skipping or stretching a step. All MAVLink time fields are this sim time.

Python API (tests, tools):
    w = World(WorldConfig(drones=1, rovers=1, endpoints={0: ["udpin:127.0.0.1:14560"]}))
    w.start_thread(); ...; w.stop()          # or: asyncio.run(w.run())
    w.vehicles[0].ap, w.vehicles[0].link.stats, w.t
"""
from __future__ import annotations

import asyncio
import os
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from vehicle.autopilot import CopterAutopilot, ParamStore, RoverAutopilot
from vehicle.autopilot.mission_persist import PersistentMissionStore, missions_path
from vehicle.autopilot.mission_store import MISSION, MissionItem, MissionStore
from vehicle.autopilot.params import COPTER_TABLE, ROVER_TABLE, core_table, read_parm_file
from vehicle.link import VehicleLink

DEFAULT_HOME = (-35.363261, 149.165230, 584.0)      # ArduPilot SITL's default (CMAC)
DEFAULT_STATE_DIR = os.path.join(os.environ.get("XDG_STATE_HOME", os.path.expanduser("~/.local/state")),
                                 "towerlink", "sitl")
AP_RATE = 50.0
SHARE_RATE = 10.0        # Hz sim: GLOBAL_POSITION_INT heard by the other vehicles (FOLLOW)


@dataclass
class WorldConfig:
    drones: int = 1
    rovers: int = 1
    speedup: float = 1.0
    rate: float = 400.0
    home: tuple[float, float, float] = DEFAULT_HOME
    seed: int = 0
    params_file: str | None = None
    state_dir: str | None = DEFAULT_STATE_DIR    # None: nothing persisted
    tcp_base: int | None = 5760                   # None: no default TCP endpoint
    udp_base: int | None = 14560                  # None: no default UDP endpoint
    host: str = "127.0.0.1"
    outs: list[str] = field(default_factory=list)              # added to every vehicle
    endpoints: dict[int, list[str]] = field(default_factory=dict)  # vehicle index -> replaces defaults
    sysid_base: int = 1
    signing_key: bytes | None = None
    missions: dict[int, list[MissionItem]] = field(default_factory=dict)  # vehicle index -> MISSION at start

    def vehicle_endpoints(self, i: int) -> list[str]:
        if i in self.endpoints:
            eps = list(self.endpoints[i])
        else:
            eps = []
            if self.tcp_base:
                eps.append(f"tcpin:{self.host}:{self.tcp_base + 10 * i}")
            if self.udp_base:
                eps.append(f"udpin:{self.host}:{self.udp_base + 10 * i}")
        return eps + list(self.outs)


@dataclass
class Vehicle:
    index: int
    kind: str          # "copter" | "rover"
    kind_index: int
    ap: object
    link: VehicleLink

    @property
    def sysid(self) -> int:
        return self.ap.sysid


class World:
    def __init__(self, cfg: WorldConfig) -> None:
        from vehicle.fleet import CopterFleet, RoverFleet   # the physics/control cores
        if cfg.rate <= 0 or cfg.speedup <= 0:
            raise ValueError("rate and speedup must be positive")
        self.cfg = cfg
        self.dt = 1.0 / cfg.rate
        self.ap_every = max(1, int(round(cfg.rate / AP_RATE)))
        self.share_every = self.ap_every * max(1, int(round(AP_RATE / SHARE_RATE)))
        self.steps = 0
        self.t = 0.0
        self.unix_start_us = int(time.time() * 1e6)
        self.vehicles: list[Vehicle] = []
        self.fleets: list[tuple[str, object]] = []
        file_params = read_parm_file(cfg.params_file) if cfg.params_file else {}
        file_params.pop("SYSID_THISMAV", None)
        index = 0
        for kind, n, table, fleet_cls, ap_cls in (
                ("copter", cfg.drones, COPTER_TABLE, CopterFleet, CopterAutopilot),
                ("rover", cfg.rovers, ROVER_TABLE, RoverFleet, RoverAutopilot)):
            if n <= 0:
                continue
            core = core_table(kind)
            core_names = {d.name for d in core}
            stores, saves = [], []
            for j in range(n):
                defaults = dict(file_params)
                defaults["SYSID_THISMAV"] = cfg.sysid_base + index + j
                save = (os.path.join(cfg.state_dir, f"{'drone' if kind == 'copter' else 'rover'}{j}.parm")
                        if cfg.state_dir else None)
                stores.append(ParamStore(core + table, defaults, save))
                saves.append(save)
            starts = np.array([self.start_position(kind, j) for j in range(n)], float)
            fleet_params = {name: stores[0][name] for name in core_names} if core_names else \
                {name: stores[0][name] for name in stores[0].names}
            fleet = fleet_cls(n, fleet_params, cfg.seed + (0 if kind == "copter" else 7919), starts)
            for j in range(1, n):          # each vehicle starts from its own (saved) parameters
                own = {name: stores[j][name] for name in fleet_params if name in stores[j]}
                if any(own[k] != fleet_params[k] for k in own):
                    fleet.set_params(own, i=j)
            self.fleets.append((kind, fleet))
            for j in range(n):
                push = self._pusher(fleet, core_names, j)
                # missions, fence and rally points persist beside the parameters
                missions = PersistentMissionStore(missions_path(saves[j])) if saves[j] else MissionStore()
                ap = ap_cls(fleet, j, stores[j], cfg.home, starts[j], push_params=push, missions=missions)
                link = VehicleLink(ap, self.clock, self.unix_start_us, cfg.vehicle_endpoints(index),
                                   signing_key=cfg.signing_key, params_changed=push)
                self.vehicles.append(Vehicle(index, kind, j, ap, link))
                if index in cfg.missions:        # --mission I=FILE: as if uploaded at start
                    ap.missions.replace_all(MISSION, cfg.missions[index])
                    ap.mission_uploaded(MISSION)
                index += 1
        self._stop: asyncio.Event | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self.ready = threading.Event()
        self.behind_events = 0

    @staticmethod
    def start_position(kind: str, j: int) -> tuple[float, float, float]:
        """World NED start of the j-th drone / rover: drones on the y axis from the origin
        every 2 m, rovers 3 m south of them."""
        return (0.0, 2.0 * j, 0.0) if kind == "copter" else (-3.0, 2.0 * j, 0.0)

    @staticmethod
    def _pusher(fleet, core_names, j):
        """Parameter changes of vehicle j (PARAM_SET, DO_CHANGE_SPEED) reach vehicle j only."""
        def push(values: dict) -> None:
            sel = {k: float(v) for k, v in values.items() if not core_names or k in core_names}
            if sel:
                fleet.set_params(sel, i=j)
        return push

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

    # ----- stepping ---------------------------------------------------------------------
    def step(self) -> None:
        dt = self.dt
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
        self._loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        await self.start_endpoints()
        for v in self.vehicles:
            v.ap.update(self.t)
        if started is not None:
            started()
        self.ready.set()
        try:
            await self._lockstep()
        finally:
            for v in self.vehicles:
                v.link.close()

    async def _lockstep(self) -> None:
        speedup, dt = self.cfg.speedup, self.dt
        chunk = 0.02                   # wall seconds of stepping before yielding to I/O
        min_sleep = 0.004              # fewer, larger sleeps: steps bunch up, sim time does not care
        max_lag = max(0.1 * speedup, 4 * dt)
        wall0, sim0 = time.monotonic(), self.t
        while not self._stop.is_set():
            now = time.monotonic()
            target = sim0 + speedup * (now - wall0)
            if target - self.t > max_lag:
                # the CPU cannot keep up: forget the backlog beyond max_lag, so the world runs
                # slower than asked, never skipping or stretching a step, and never bursting
                self.behind_events += 1
                wall0 = now - (self.t + max_lag - sim0) / speedup
                target = self.t + max_lag
            deadline = now + chunk
            n = 0
            while self.t + 0.5 * dt <= target:
                self.step()
                n += 1
                if (n & 3) == 0 and time.monotonic() > deadline:
                    break
            if self.t + 0.5 * dt <= target:
                await asyncio.sleep(0)          # behind: serve I/O, then keep stepping
                continue
            next_wall = wall0 + (self.t + dt - sim0) / speedup
            await asyncio.sleep(max(min_sleep, next_wall - time.monotonic()))

    def request_stop(self) -> None:
        if self._loop is not None and self._stop is not None:
            self._loop.call_soon_threadsafe(self._stop.set)

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

    def banner(self) -> str:
        lines = [f"towerlink sitl: {len(self.vehicles)} vehicle(s), home {self.cfg.home[0]:.6f},"
                 f"{self.cfg.home[1]:.6f},{self.cfg.home[2]:.1f}, rate {self.cfg.rate:g} Hz, "
                 f"speedup {self.cfg.speedup:g}, seed {self.cfg.seed}"]
        for v in self.vehicles:
            name = "drone" if v.kind == "copter" else "rover"
            lines.append(f"  vehicle {v.index}: {name} sysid {v.sysid} ({'QUADROTOR' if v.kind == 'copter' else 'GROUND_ROVER'})"
                         f"  {'  '.join(v.link.specs)}")
        return "\n".join(lines)

    def stats_line(self) -> str:
        parts = []
        for v in self.vehicles:
            s = v.link.stats
            parts.append(f"sysid {v.sysid}: " + " ".join(f"{k}={s[k]}" for k in sorted(s)))
        return "stats: " + "; ".join(parts)
