"""How a `towerlink fly` run is made: its options checked, its ports, every process's command line.

A FlyPlan is what the launcher (tools.fly_launch) starts and what meta.json records. Nothing
here starts a process: building the commands only picks free ports (common.ports) and, for a
van scenario, writes the van's mission into the run folder.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

from common.mavlink.lockstep import speedup_text
from common.mavlink.signing import SIGNING_FLAG
from common.ports import free_udp_ports
from tools.fly_van import write_van_mission
from tools.run_ids import ROVER

SITL_HOME = (-35.363261, 149.16523, 584.0)     # towerlink sitl's default --home (ArduPilot's CMAC)
FOLLOW_WITH = ("bridge", "ardupilot", "both")


def towerlink_cmd(*args: str) -> list[str]:
    """The command line that runs `towerlink ARGS` with this interpreter."""
    return [sys.executable, "-m", "tools.cli", *args]


class FlyPlan:
    """The options of one run, checked (ValueError), its ports and its processes' command lines.

    `speedup` is sim seconds per wall second (float('inf'): --speedup max); `lockstep` puts the
    world, the bridge, the tower (and a van's driver) in whole-system lockstep; `world` is a
    tools.hosts.WorldHost when the world runs on another host (None: here); `signing_key` is the
    text as given (passphrase or 64 hex digits), each process reads it with
    common.mavlink.signing.key_from_text and it is never written in clear.
    """

    def __init__(self, run_dir: str | os.PathLike, *, scenario: str | None = None,
                 speedup: float = 5.0, seed: int = 1, follow_frame: str | None = None,
                 goals: str | None = None, alt: float | None = None, radius: float | None = None,
                 finish: str | None = None, goal_timeout: float = 120.0, tower_loss: float = 0.0,
                 tower_link: str | None = None, loss_seed: int | None = None,
                 start_params: dict[str, float] | None = None, sitl_args: tuple[str, ...] = (), bridge_args: tuple[str, ...] = (),
                 tower_args: tuple[str, ...] = (), host: str = "127.0.0.1",
                 nodes: str | os.PathLike | list | None = None, lockstep: bool = False,
                 lockstep_pipeline: bool = True, follow_with: str = "bridge",
                 foll_pos_p: float | None = None, world=None, signing_key: str | None = None) -> None:
        from common.scenario import load_scenario, scenario_path
        self.dir = Path(run_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.scenario = str(scenario_path(scenario).resolve()) if scenario else None
        self.sc = load_scenario(self.scenario)
        self.family = self.sc.is_family
        self.speedup = speedup
        self.lockstep = lockstep
        self.lockstep_pipeline = lockstep_pipeline      # sitl --lockstep-pipeline (with lockstep)
        self.seed = seed
        self.follow_frame = follow_frame
        self.goals, self.alt, self.radius, self.finish = goals, alt, radius, finish
        self.goal_timeout = goal_timeout
        self.tower_loss = tower_loss
        self.tower_link = tower_link or None
        self.loss_seed = seed if loss_seed is None else loss_seed     # the link's draws
        self.start_params = dict(start_params or {})
        self.timeline = self._timeline()
        self.sitl_args, self.bridge_args, self.tower_args = sitl_args, bridge_args, tower_args
        self.host = host
        self.world = world
        if isinstance(nodes, (list, tuple)):     # the node files themselves (towerlink lab check)
            self.nodes = [Path(p) for p in nodes]
        else:
            self.nodes = sorted(Path(nodes).glob("*.py")) if nodes else []
            if nodes and not self.nodes:
                raise ValueError(f"no nodes (*.py) in {nodes}")
        self.signing_key = signing_key or None
        if self.signing_key and self.nodes:
            raise ValueError("--signing-key with --nodes: the nodes (common.tf2_ros) cannot sign yet, and the "
                             "bridge's node link takes only signed packets with a key")
        names = ["drone", "rover", "tower", "vehicles", "bridge", "proxy", "nodes"]
        if self.family:
            names += [f"vehicle{s}" for _n, s, _k in self.sc.vehicles]
            if self.sc.van is not None:
                names.append("van_driver")
        self.ports = dict(zip(names, free_udp_ports(len(names), host)))
        if follow_with not in FOLLOW_WITH:
            raise ValueError(f"--follow-with: bridge, ardupilot or both, not {follow_with!r}")
        # who follows the drone: the bridge's tf follow drives rover sysid 2; ArduPilot's FOLLOW
        # (tools/follow_ap.py) drives sysid 2 instead, or a second rover (sysid 3) beside it
        if follow_with != "bridge" and self.family:
            raise ValueError("--follow-with ardupilot|both flies the lab's drone and rover, not a family")
        self.follow_with = follow_with
        self.foll_pos_p = foll_pos_p
        self.ap_follower = {"bridge": None, "ardupilot": ROVER, "both": ROVER + 1}[follow_with]

    def _timeline(self):
        """The run's fault timeline: the scenario's [[faults]] over the tower link's own settings
        (--tower-loss, then --tower-link); ValueError for a bad setting or parameter."""
        from common.link_settings import parse_link_spec, settings_pair
        from tools.fault_timeline import FaultTimeline
        from tools.vehicle_params import param_table
        changes = {"loss": self.tower_loss} if self.tower_loss else {}
        try:
            changes.update(parse_link_spec(self.tower_link or ""))
            base = settings_pair(changes)
        except ValueError as exc:
            raise ValueError(f"--tower-link: {exc}") from None
        kinds = {sysid: kind for _name, sysid, kind in self.sc.vehicles}
        tables = {kind: param_table(kind) for kind in set(kinds.values())} if self.sc.faults else {}
        return FaultTimeline(self.sc.faults, base, kinds, tables, self.start_params)

    @property
    def uses_proxy(self) -> bool:
        """Does the tower talk through the link proxy (tools.link_proxy)? When the link has
        faults, and when the scenario's vehicle faults need it to send their PARAM_SETs."""
        return self.timeline.touches_link or bool(self.sc.faults)

    # -- where things are

    @property
    def followed_frame(self) -> str:
        """The frame the rover's goal is written in: --follow-frame, else the scenario's."""
        return self.follow_frame or self.sc.follow_frame

    def world_binds(self) -> tuple[str, str]:
        """(where the world's endpoints listen, where it pushes its telemetry)."""
        return (self.world.bind, self.world.local) if self.world else (self.host, self.host)

    @property
    def world_addr(self) -> str:
        """Where the bridge (and the van's driver) reach the world's endpoints."""
        return self.world.addr if self.world else self.host

    def key(self) -> bytes | None:
        """The signing key as bytes (None without one)."""
        from common.mavlink.signing import key_from_text
        return key_from_text(self.signing_key)

    def signing_args(self) -> list[str]:
        """--signing-key KEY for the world, the bridge and the tower (none without a key)."""
        return [SIGNING_FLAG, self.signing_key] if self.signing_key else []

    def scenario_wind(self) -> list[str]:
        """The scenario's wind table as `sitl --wind` (none when it has no wind)."""
        if not self.scenario:
            return []
        w = self.sc.wind_arg()
        return ["--wind", w] if w else []

    # -- command lines

    def sitl_cmd(self) -> list[str]:
        """`towerlink sitl`: the lab's drone and rover, or every vehicle of a family."""
        if self.family:
            return self.family_sitl_cmd()
        h, out = self.world_binds()
        # the lockstep participants: the bridge, the tower and the monitor on the push link
        # (tools.fly_monitor: it records the truth the summary scores); the world waits for all at t=0
        lock = ("--lockstep", "3", *self.pipeline_args()) if self.lockstep else ()
        return towerlink_cmd("sitl", "--speedup", speedup_text(self.speedup), "--seed", str(self.seed),
                             "--no-save", "--tcp-base", "0", "--udp-base", "0",
                             "--endpoint", f"0=udpin:{h}:{self.ports['drone']}",
                             "--endpoint", f"1=udpin:{h}:{self.ports['rover']}",
                             "--out", f"udpout:{out}:{self.ports['vehicles']}", *self.scenario_wind(),
                             *lock, *(("--rovers", "2") if self.follow_with == "both" else ()),
                             *self.signing_args(), *self.sitl_args)

    def pipeline_args(self) -> tuple[str, ...]:
        """The world's lockstep pipelined (reactions one TICK later), or not."""
        return ("--lockstep-pipeline",) if self.lockstep_pipeline else ()

    def family_sitl_cmd(self) -> list[str]:
        """Every vehicle of the scenario, vehicle i (sysid i+1) on its own udpin port."""
        (h, out), sc = self.world_binds(), self.sc
        cmd = towerlink_cmd("sitl", "--drones", str(len(sc.drones)), "--rovers", str(len(sc.rovers)),
                            "--speedup", speedup_text(self.speedup), "--seed", str(self.seed), "--no-save",
                            "--tcp-base", "0", "--udp-base", "0",
                            "--home=" + ",".join(f"{v:.10g}" for v in SITL_HOME),   # "=": it starts with "-"
                            "--out", f"udpout:{out}:{self.ports['vehicles']}", *self.scenario_wind())
        if self.lockstep:
            # the bridge, the family's one tower link (gcs.tower_link), the monitor and the van's driver
            cmd += ["--lockstep", str(3 + (sc.van is not None)), *self.pipeline_args()]
        for _name, sysid, _kind in sc.vehicles:
            cmd += ["--endpoint", f"{sysid - 1}=udpin:{h}:{self.ports[f'vehicle{sysid}']}"]
        if sc.van is not None:
            i = sc.van.sysid - 1
            mission = write_van_mission(sc.van, SITL_HOME, self.dir / "van.waypoints")
            cmd += ["--endpoint", f"{i}=udpin:{h}:{self.ports['van_driver']}", "--mission", f"{i}={mission}"]
        return cmd + self.signing_args() + list(self.sitl_args)

    def world_cmd(self) -> list[str]:
        """The command that starts the world, where it runs (--world-cmd-prefix)."""
        return self.world.command(self.sitl_cmd()) if self.world else self.sitl_cmd()

    def bridge_cmd(self) -> list[str]:
        """`towerlink bridge` between the tower link and every vehicle's link."""
        h, w = self.host, self.world_addr
        if self.family:
            vehicles = []
            for _name, sysid, _kind in self.sc.vehicles:
                vehicles += ["--vehicle", f"{sysid}=udpout:{w}:{self.ports[f'vehicle{sysid}']}"]
        else:
            vehicles = ["--drone", f"udpout:{w}:{self.ports['drone']}",
                        "--rover", f"udpout:{w}:{self.ports['rover']}"]
        cmd = towerlink_cmd("bridge", "--tower", f"udpin:{h}:{self.ports['tower']}", *vehicles,
                            "--out", f"udpout:{h}:{self.ports['bridge']}",
                            "--speedup", speedup_text(self.speedup))
        if self.lockstep:
            cmd.append("--lockstep")
        if self.scenario:
            cmd += ["--scenario", self.scenario]
        if self.follow_frame:
            cmd += ["--follow-frame", self.follow_frame]
        if self.nodes:
            cmd += ["--nodes", f"udpin:{h}:{self.ports['nodes']}", "--route-only"]
            if self.lockstep:           # the nodes join the lockstep through the bridge
                cmd += ["--lockstep-nodes", str(len(self.nodes))]
        if self.follow_with == "ardupilot":
            cmd += ["--no-follow"]          # the rover follows in its own FOLLOW mode
        if self.signing_key:                # the vehicles sign too: the bridge checks them as well
            cmd += [*self.signing_args(), "--vehicle-signing"]
        return cmd + list(self.bridge_args)

    def node_cmd(self, path: Path) -> list[str]:
        """A tf2_ros node of --nodes DIR, connected to the bridge's node link."""
        return [sys.executable, str(path), "--connect", f"udpout:{self.host}:{self.ports['nodes']}",
                "--follow-frame", self.followed_frame]

    def node_env(self) -> dict[str, str]:
        """What a node's environment adds: with lockstep, common.tf2_ros nodes join it."""
        from common.tf2_ros.node import LOCKSTEP_ENV
        return {LOCKSTEP_ENV: "1" if self.lockstep else "0"}

    def tower_url(self) -> str:
        """Where the tower connects: the bridge's tower link, or the link proxy in front of it."""
        port = self.ports["proxy"] if self.uses_proxy else self.ports["tower"]
        return f"udpout:{self.host}:{port}"

    def tower_cmd(self) -> list[str]:
        """`towerlink tower` flying the scenario's mission (or --goals), its result in tower.json."""
        cmd = towerlink_cmd("tower", "--connect", self.tower_url(),
                            "--result", str(self.dir / "tower.json"), "--tlog", str(self.dir / "tower.tlog"),
                            "--goal-timeout", f"{self.goal_timeout:g}")
        if self.lockstep:
            cmd.append("--lockstep")
        for flag, v in (("--scenario", self.scenario), ("--goals", self.goals), ("--alt", self.alt),
                        ("--radius", self.radius), ("--finish", self.finish)):
            if v is not None:
                cmd.append(f"{flag}={v}")  # '=': goals may start with '-'
        return cmd + self.signing_args() + list(self.tower_args)

    def commands(self) -> dict[str, list[str]]:
        """Every process's command line by name (sitl, bridge, tower, node-<name>), as meta.json
        records them."""
        return {"sitl": self.world_cmd(), "bridge": self.bridge_cmd(), "tower": self.tower_cmd(),
                **{f"node-{p.stem}": self.node_cmd(p) for p in self.nodes}}
