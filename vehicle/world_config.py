"""What a SITL world is made of: WorldConfig (the options of `towerlink sitl`, the Python
API's argument) and the defaults it starts from."""
from __future__ import annotations

import os
from dataclasses import dataclass, field

from vehicle.autopilot.mission_store import MissionItem
from vehicle.network_plan import NetworkPlan
from vehicle.network_plan import plan as plan_world
from vehicle.physics.wind import WindParams

DEFAULT_HOME = (-35.363261, 149.165230, 584.0)      # ArduPilot SITL's default (CMAC)
PLAN_FILE = "network_plan.json"      # in the state dir: the network plan of the running world
DEFAULT_STATE_DIR = os.path.join(os.environ.get("XDG_STATE_HOME", os.path.expanduser("~/.local/state")),
                                 "towerlink", "sitl")


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
    sysids: dict[int, int] = field(default_factory=dict)       # vehicle index -> explicit sysid
    group_size: int | None = None                               # vehicles per MAVLink network (default 254)
    share: tuple[int, int] | None = None      # vehicle indices [lo, hi) this process runs (--workers)
    start_at: float | None = None             # unix time of sim t = 0 (default: now)
    wind: WindParams | None = None            # None: from the vehicles' SIM_WIND_* parameters
    # whole-system lockstep: 0 = off; N = wait at t = 0 for N participants
    lockstep: int = 0
    lockstep_period: float = 0.04     # sim s between TICKs (a multiple of the 50 Hz autopilot tick)
    lockstep_timeout: float = 10.0    # wall s a participant may stay silent before it is dropped
    # pipelined lockstep: TICK(t) goes out and the world steps on at once, waiting for ACK(t) at
    # t + lockstep_period; a participant's reactions to TICK(t) take effect one period later
    lockstep_pipeline: bool = False

    def network_plan(self) -> NetworkPlan:
        """Sysids, networks and ports of every vehicle (vehicle/network_plan.py); PlanError."""
        return plan_world(self.drones, self.rovers, tcp_base=self.tcp_base, udp_base=self.udp_base,
                          host=self.host, outs=self.outs, endpoints=self.endpoints,
                          sysid_base=self.sysid_base, sysids=self.sysids, group_size=self.group_size)

    def saved_params_path(self, kind: str, j: int) -> str | None:
        """Where drone<j> / rover<j> (kind "copter" / "rover") keeps its parameters between
        starts (STATE_DIR/drone<j>.parm, as SITL's eeprom.bin); None without a state dir."""
        if not self.state_dir:
            return None
        return os.path.join(self.state_dir, f"{'drone' if kind == 'copter' else 'rover'}{j}.parm")

    def vehicle_endpoints(self, i: int) -> list[str]:
        return list(self.network_plan().vehicles[i].endpoints)

    def share_range(self) -> tuple[int, int]:
        """The vehicle indices [lo, hi) this process runs (all of them without --workers)."""
        return self.share if self.share is not None else (0, self.drones + self.rovers)
