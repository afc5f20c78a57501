"""Building a world's vehicles from its WorldConfig: per kind one batched fleet (the physics
and control cores), per vehicle its parameters (saved file, --params defaults, the plan's
sysid), its missions, its autopilot and its MAVLink link.

Vehicle j of a kind is seeded [seed, j] (7919 apart between kinds) whichever process runs
it, and starts at `start_position(kind, j)`; a process running a share of the world
(--workers) builds only the vehicles of its share.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from vehicle import sim_faults
from vehicle.autopilot.copter import CopterAutopilot
from vehicle.autopilot.mission_persist import PersistentMissionStore, missions_path
from vehicle.autopilot.mission_store import MISSION, MissionStore
from vehicle.autopilot.params import (COPTER_TABLE, ROVER_TABLE, ParamStore, _warn, core_table, file_warnings,
                                      read_parm_file)
from vehicle.autopilot.rover import RoverAutopilot
from vehicle.fleet import CopterFleet, RoverFleet
from vehicle.link.vehicle_link import VehicleLink
from vehicle.link.link_core import Intake
from vehicle.link.outbox import DIRECT, Outbox
from vehicle.logs.world_logs import WorldLogs
from vehicle.network_plan import NetworkPlan
from vehicle.physics.wind import WindParams
from vehicle.vehicle_root import vehicle_root
from vehicle.world_config import WorldConfig

# Hz: ArduRover's main loop, where its controllers, AHRS and EKF run (AP_Scheduler's
# SCHEDULER_DEFAULT_LOOP_RATE for vehicles other than copters); the kinematics step at the world's rate
ROVER_LOOP_RATE = 50.0


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


@dataclass
class Built:
    """What build() made: the fleets (kind, fleet), the vehicles in world-index order, and
    each kind's fleet rows as world indices."""
    fleets: list[tuple[str, object]]
    vehicles: list[Vehicle]
    fleet_ids: dict[str, list[int]]


def start_position(kind: str, j: int) -> tuple[float, float, float]:
    """World NED start of the j-th drone / rover: drones on the y axis from the origin
    every 2 m, rovers 3 m south of them."""
    return (0.0, 2.0 * j, 0.0) if kind == "copter" else (-3.0, 2.0 * j, 0.0)


def build(cfg: WorldConfig, plan: NetworkPlan, clock: Callable[[], float], unix_start_us: int,
          wind_set: Callable[[ParamStore], None], intake: Callable[[int], Intake | None],
          logs: WorldLogs | None = None, outbox: Outbox = DIRECT) -> Built:
    """The vehicles of cfg's share. clock(): the world's sim time (s); wind_set(store): a
    vehicle's SIM_WIND_* changed (store holds the new values); intake(index): what sees
    vehicle index's UDP datagrams first (the lockstep), or None; logs: the world's onboard
    logs (vehicle/logs/), None for none; outbox: what holds every endpoint's writes while the
    world steps (vehicle/link/outbox.py)."""
    file_params = read_parm_file(cfg.params_file) if cfg.params_file else {}
    file_params.pop("SYSID_THISMAV", None)
    lo, hi = cfg.share_range()
    out = Built([], [], {})
    first = 0                                  # world index of the kind's vehicle 0
    for kind, n, table, fleet_cls, ap_cls in (
            ("copter", cfg.drones, COPTER_TABLE, CopterFleet, CopterAutopilot),
            ("rover", cfg.rovers, ROVER_TABLE, RoverFleet, RoverAutopilot)):
        js = [j for j in range(n) if lo <= first + j < hi]     # this process's share
        if not js:
            first += n
            continue
        core = core_table(kind)
        core_names = {d.name for d in core}
        stores, saves = [], []
        for j in js:
            defaults = dict(file_params)
            defaults["SYSID_THISMAV"] = plan.vehicles[first + j].sysid
            save = cfg.saved_params_path(kind, j)
            stores.append(ParamStore(core + table, defaults, save, deferred=True))   # the link flushes
            saves.append(save)
        if cfg.params_file:          # once per kind: unknown names / bad values, not fatal
            for msg in file_warnings(file_params, stores[0].defs, kind, cfg.params_file):
                _warn(msg)
        starts = np.array([start_position(kind, j) for j in js], float)
        fleet_params = {name: stores[0][name] for name in core_names} if core_names else \
            {name: stores[0][name] for name in stores[0].names}
        base_seed = cfg.seed + (0 if kind == "copter" else 7919)
        # vehicle j's noise is seeded [seed, j] whichever process runs it
        seed = base_seed if len(js) == n else [(base_seed, j) for j in js]
        loop = {"loop_every": max(1, round(cfg.rate / ROVER_LOOP_RATE))} if kind == "rover" else {}
        fleet = fleet_cls(len(js), fleet_params, seed, starts, **loop)
        for k in range(1, len(js)):    # each vehicle starts from its own (saved) parameters
            own = {name: stores[k][name] for name in fleet_params if name in stores[k]}
            if any(own[x] != fleet_params[x] for x in own):
                fleet.set_params(own, i=k)
        out.fleets.append((kind, fleet))
        out.fleet_ids[kind] = [first + j for j in js]     # world indices (wind streams)
        for k, j in enumerate(js):     # k: index in the fleet, j: the kind's index
            index = first + j
            push = _pusher(fleet, core_names, k, stores[k], wind_set, cfg.home[0])
            if any(stores[k][name] != sim_faults.DEFAULTS[name] for name in sim_faults.NAMES if name in stores[k]):
                push({name: stores[k][name] for name in sim_faults.NAMES if name in stores[k]})
            # missions, fence and rally points persist beside the parameters
            missions = PersistentMissionStore(missions_path(saves[k])) if saves[k] else MissionStore()
            ap = ap_cls(fleet, k, stores[k], cfg.home, starts[k], push_params=push, missions=missions)
            link = VehicleLink(ap, clock, unix_start_us, list(plan.vehicles[index].endpoints),
                               signing_key=cfg.signing_key, params_changed=push, intake=intake(index),
                               files_root=vehicle_root(cfg.state_dir, index) if cfg.state_dir else None,
                               logs=logs, outbox=outbox)
            out.vehicles.append(Vehicle(index, kind, j, ap, link))
            if index in cfg.missions:        # --mission I=FILE: as if uploaded at start
                ap.missions.replace_all(MISSION, cfg.missions[index])
                ap.mission_uploaded(MISSION)
        first += n
    return out


def _pusher(fleet, core_names, j: int, store: ParamStore, wind_set: Callable[[ParamStore], None],
            lat: float):
    """Parameter changes of vehicle j (PARAM_SET, DO_CHANGE_SPEED) reach vehicle j only;
    SIM_WIND_* change the world's air (there is one) and every vehicle's copy of them; the
    other SIM_* faults (vehicle.sim_faults) vehicle j's sensors and motors (lat: the world's
    home latitude, for a longitude glitch in metres)."""
    def push(values: Mapping[str, float]) -> None:
        sel = {k: float(v) for k, v in values.items() if not core_names or k in core_names}
        if sel:
            fleet.set_params(sel, i=j)
        if any(k in WindParams.NAMES for k in values):
            wind_set(store)
        if any(k in sim_faults.NAMES for k in values):
            fleet.set_faults(j, sim_faults.SimFaults.from_params(store.values, lat))
    return push
