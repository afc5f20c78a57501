"""Fly the lab: start the SITL world, the bridge and the tower, watch, stop, summarise.

The lab's fly.launch as one command (and the README's `make demo`):

  towerlink fly                                  # default scenario, speedup 5, rover follows drone_yaw
  towerlink fly my.toml --follow-frame drone     # the wobbling checkpoint-2 frame
  towerlink fly --goals="-131.04,73.52;-105.06,88.52;-120.06,114.50" --seed 3
  towerlink fly --nodes examples/lab             # the lab's three nodes do the transforms and the follow

Three processes on loopback with free ports (so several runs can share a machine):

  towerlink sitl    drone (sysid 1) + rover (sysid 2), --speedup, --seed, pushing
                    every vehicle's telemetry to this launcher (vehicles.tlog)
  towerlink bridge  tower link <-> vehicles, tower <-> world translation, rover follow,
                    transform stream pushed to this launcher (bridge.tlog)
  towerlink tower   the mission in tower coordinates (tower.tlog, tower.json)

With --nodes DIR every DIR/*.py is started as a node (common.tf2_ros), `python FILE
--connect udpout:127.0.0.1:PORT --follow-frame FRAME` (node-<name>.log), and the bridge
gets --nodes udpin:127.0.0.1:PORT --route-only: the nodes publish the drone's frames,
turn the tower's goals into world goals and drive the rover; the bridge only routes (and
keeps the frames' authority).

While they run it prints one progress line a second (goal n/N, drone position,
rover follow error from truth, sim time and the speedup achieved). At the end, on
Ctrl-C, or on any failure, every process it started is stopped. Then it writes the
run folder (--out, default runs/<timestamp>):

  vehicles.tlog bridge.tlog tower.tlog   one tlog per link
  tower.json meta.json                   the tower's result; how the run was made
  summary.json summary.txt               the scores (also printed)
  tracks.png                             drone, rover, goals, tower; follow error and wobble
  frames.pdf frames.png frames.yaml      the frame tree, as view-frames draws it
  sitl.log bridge.log tower.log          each process's output

The summary gives per goal its tower and world coordinates, time to reach (sim s)
and the ratio to the minimum time d/v + v/a + a/j (the drone's WPNAV_SPEED,
WPNAV_ACCEL and PSC_JERK_XY); the rover's follow error (RMS and max against the
drone's ground point, from truth); and the wobble figure for both follow frames
(the bridge computes the ground point through the full-attitude and the yaw-only
frame on every follow tick, whichever one it steers by).

With --world-host ADDR the world runs on another host (tools/hosts.py), the bridge and the
tower here; it listens on 0.0.0.0 there and pushes telemetry to this host:

  towerlink fly --world-host 10.0.0.2 --world-cmd-prefix "ssh -tt sim-box"
  towerlink fly --world-host 10.211.0.1 --world-cmd-prefix "ip netns exec simA"

A family or van scenario (`towerlink fly family`, `towerlink fly van`; shipped
scenarios are named without .toml): the world starts every vehicle the scenario lists
(--drones N --rovers M, one loopback port each), the bridge serves each (--vehicle
SYSID=URL) with a follower per (drone, rover) pair, and the tower flies every drone at
once. A van gets its route as a mission (van.waypoints: DO_CHANGE_SPEED, the route,
DO_JUMP back, forever) and a driver on a port of its own puts it in AUTO and arms it
(van.log). The summary then has a row per vehicle, a row per goal of every drone (with
the time-travel figure when the tower rides the van) and the closest approach of two
airborne drones; tracks.png draws every vehicle. `towerlink fly family100 --speedup
max` flies 100 drones (common/family_plan.py: own lanes, two altitude layers, no rovers; the summary
then counts per layer).

Lockstep (issue 11) is the default: the world waits for the bridge, the tower (a family's
one shared link) and the van's driver (TOWERLINK_LOCKSTEP), so a seed gives the
same summary figures at any --speedup (max: as fast as the machine allows) and under any CPU
load. --no-lockstep runs the old free-running world (figures then depend on the machine):

  towerlink fly --speedup max            # lockstep, as fast as the machine allows
  towerlink fly family --speedup max
  towerlink fly --no-lockstep            # free-running world

MAVLink 2 signing: --signing-key PASSPHRASE|HEX64 runs the whole chain signed. The world's
vehicles sign, drop unsigned packets and check the lockstep JOIN/ACK/LEAVE (sitl
--signing-key); the bridge takes only signed packets on the tower link and the vehicle links
and signs what it sends (bridge --signing-key --vehicle-signing); the tower and the van's
driver sign everything and accept only signed packets. The key is masked (***) in the run
folder's logs and meta.json:

  towerlink fly --signing-key "my passphrase" --speedup max

Exit status 0 iff the tower reached every goal.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

from common.geo import lla_to_ned, ned_to_lla
from common.mavlink.lockstep import speedup_text, speedup_type
from common.mavlink.mavstr import mav_str
from common.mavlink.signing import SIGNING_FLAG, add_signing_argument, masked_argv
from common.ports import free_udp_ports
from tools.procs import die_with_parent

os.environ.setdefault("MAVLINK20", "1")

DRONE, ROVER = 1, 2
SITL_HOME = (-35.363261, 149.16523, 584.0)     # towerlink sitl's default --home (ArduPilot's CMAC)
SCORING_PARAMS = ("WPNAV_SPEED", "WPNAV_ACCEL", "PSC_JERK_XY")




def towerlink_cmd(*args: str) -> list[str]:
    """The command line that runs `towerlink ARGS` with this interpreter."""
    return [sys.executable, "-m", "tools.cli", *args]


# ----------------------------------------------------------------------------- monitor


class Monitor(threading.Thread):
    """Listens where the world and the bridge push, records a tlog per link, tracks progress."""

    def __init__(self, run_dir: Path, ports: dict[str, int], host: str = "127.0.0.1",
                 binds: dict[str, str] | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(daemon=True, name="fly-monitor")
        from common.mavlink.dialect import towerlink as tl
        self.tl = tl
        self.socks: dict[str, socket.socket] = {}
        self.parsers = {}
        self.tlogs = {}
        for name, port in ports.items():
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(((binds or {}).get(name, host), port))    # binds: a link heard from another host
            s.setblocking(False)
            self.socks[name] = s
            p = tl.MAVLink(None)
            p.robust_parsing = True
            self.parsers[name] = p
            self.tlogs[name] = open(run_dir / f"{name}.tlog", "wb")
        self.encoder = tl.MAVLink(None, srcSystem=255, srcComponent=158)
        if signing_key:     # vehicles given the key drop unsigned requests (the scoring parameters)
            from gcs.client import SIGNING_LINK_ID
            from common.mavlink.signing import setup_signing
            setup_signing(self.encoder, signing_key, SIGNING_LINK_ID)
        self._halt = threading.Event()
        self.lock = threading.Lock()
        self.sim_ms = 0
        self.origin: dict[int, tuple[float, float, float]] = {}
        self.truth: dict[int, tuple[float, float, float]] = {}
        self.estimate: dict[int, tuple[float, float, float]] = {}
        self.params: dict[str, float] = {}
        self.follow = None
        self.counts = {name: 0 for name in ports}
        self.addr_of: dict[tuple[str, int], tuple] = {}   # (link, sysid) -> where it sends from
        self.listeners: dict[str, object] = {}    # link name -> callable(message), e.g. the live view

    def run(self) -> None:
        import selectors
        sel = selectors.DefaultSelector()
        for name, s in self.socks.items():
            sel.register(s, selectors.EVENT_READ, name)
        try:
            while not self._halt.is_set():
                for key, _ in sel.select(timeout=0.1):
                    name = key.data
                    while True:
                        try:
                            data, addr = key.fileobj.recvfrom(65535)
                        except (BlockingIOError, InterruptedError):
                            break
                        except OSError:
                            break
                        self._datagram(name, data, addr)
        finally:
            sel.close()

    def _datagram(self, name: str, data: bytes, addr=None) -> None:
        try:
            msgs = self.parsers[name].parse_buffer(data) or []
        except Exception:  # noqa: BLE001 - a monitor never dies of a bad packet
            return
        usec = struct.pack(">Q", int(time.time() * 1e6) & ~3)
        f = self.tlogs[name]
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                continue
            f.write(usec + m.get_msgbuf())
            self.counts[name] += 1
            if addr is not None:
                self.addr_of[(name, m.get_srcSystem())] = addr
            self._track(m)
            listener = self.listeners.get(name)
            if listener is not None:
                try:
                    listener(m)
                except Exception:  # noqa: BLE001 - a viewer's fault must not stop the recording
                    self.listeners.pop(name, None)

    def _track(self, m) -> None:
        t = m.get_type()
        src = m.get_srcSystem()
        ms = getattr(m, "time_boot_ms", None)
        with self.lock:
            if isinstance(ms, int) and src in (DRONE, ROVER) and t != "SET_POSITION_TARGET_LOCAL_NED":
                self.sim_ms = max(self.sim_ms, ms)
            # each vehicle's local NED is centred on its own EKF origin (GPS_GLOBAL_ORIGIN, or
            # HOME_POSITION's lla less its local x, y, z); world is the drone's, as the bridge's
            if t == "HOME_POSITION" and src not in self.origin:
                self.origin[src] = ned_to_lla((m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3),
                                              (-m.x, -m.y, -m.z))
            elif t == "GPS_GLOBAL_ORIGIN":
                self.origin[src] = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
            elif t == "SIM_STATE" and DRONE in self.origin:
                lat = m.lat_int * 1e-7 if getattr(m, "lat_int", 0) else m.lat
                lon = m.lon_int * 1e-7 if getattr(m, "lon_int", 0) else m.lon
                self.truth[src] = lla_to_ned(self.origin[DRONE], lat, lon, m.alt)
            elif t == "LOCAL_POSITION_NED":
                off = (lla_to_ned(self.origin[DRONE], *self.origin[src])
                       if DRONE in self.origin and src in self.origin else (0.0, 0.0, 0.0))
                self.estimate[src] = (m.x + off[0], m.y + off[1], m.z + off[2])
            elif t == "PARAM_VALUE" and src == DRONE:
                self.params[mav_str(m.param_id)] = float(m.param_value)
            elif t == "TOWERLINK_FOLLOW_STATUS":
                self.follow = m

    def send_to_vehicle(self, sysid: int, msg) -> bool:
        """`msg` to vehicle `sysid` through the world's push link (its own socket); False if
        that vehicle has not been heard yet."""
        addr = self.addr_of.get(("vehicles", sysid))
        if addr is None:
            return False
        try:
            self.socks["vehicles"].sendto(msg.pack(self.encoder), addr)
        except OSError:
            return False
        return True

    def request_params(self, names=SCORING_PARAMS) -> None:
        """Ask the drone (through the world's push link, at the address the drone sends from:
        every vehicle pushes to this one socket) for the parameters the scoring needs."""
        for n in names:
            if n not in self.params:
                self.send_to_vehicle(DRONE, self.tl.MAVLink_param_request_read_message(DRONE, 1, n.encode(), -1))

    def snapshot(self) -> dict:
        with self.lock:
            d = self.truth.get(DRONE) or self.estimate.get(DRONE)
            r = self.truth.get(ROVER) or self.estimate.get(ROVER)
            err = math.hypot(d[0] - r[0], d[1] - r[1]) if d and r else None
            return {"sim": self.sim_ms / 1000.0, "drone": d, "rover": r, "follow_err": err}

    def stop(self) -> None:
        self._halt.set()
        if self.is_alive():
            self.join(2.0)
        for s in self.socks.values():
            s.close()
        for f in self.tlogs.values():
            f.close()


# ----------------------------------------------------------------------------- launch


class Launch:
    """The three processes of a run and the monitor; `stop()` always leaves nothing behind.

    Used by `towerlink fly` and by the full-system tests (which also kill and restart
    the bridge, or put a lossy proxy on the tower link).
    """

    def __init__(self, run_dir: str | os.PathLike, *, scenario: str | None = None,
                 speedup: float = 5.0, seed: int = 1, follow_frame: str | None = None,
                 goals: str | None = None, alt: float | None = None, radius: float | None = None,
                 finish: str | None = None, goal_timeout: float = 120.0, tower_loss: float = 0.0,
                 loss_seed: int = 1, sitl_args: tuple[str, ...] = (), bridge_args: tuple[str, ...] = (),
                 tower_args: tuple[str, ...] = (), echo: bool = False, host: str = "127.0.0.1",
                 view_port: int | None = None, nodes: str | os.PathLike | None = None,
                 lockstep: bool = False, follow_with: str = "bridge", foll_pos_p: float | None = None,
                 world=None, signing_key: str | None = None) -> None:
        from common.scenario import load_scenario, scenario_path
        self.dir = Path(run_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.scenario = str(scenario_path(scenario).resolve()) if scenario else None
        self.sc = load_scenario(self.scenario)
        self.family = self.sc.is_family
        self.speedup = speedup          # float('inf'): --speedup max
        self.lockstep = lockstep        # issue 11: world, bridge and tower in lockstep
        self.seed = seed
        self.follow_frame = follow_frame
        self.goals, self.alt, self.radius, self.finish = goals, alt, radius, finish
        self.goal_timeout = goal_timeout
        self.tower_loss = tower_loss
        self.loss_seed = loss_seed
        self.sitl_args, self.bridge_args, self.tower_args = sitl_args, bridge_args, tower_args
        self.echo = echo
        self.host = host
        self.world = world      # tools.hosts.WorldHost: the world runs on another host; None: here
        self.nodes = sorted(Path(nodes).glob("*.py")) if nodes else []
        if nodes and not self.nodes:
            raise ValueError(f"no nodes (*.py) in {nodes}")
        # MAVLink 2 signing for the whole run (the text as given: passphrase or 64 hex digits);
        # each process reads it with common.mavlink.signing.key_from_text; never written in clear
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
        self.van_driver: threading.Thread | None = None
        self._van_stop = threading.Event()
        self.procs: dict[str, subprocess.Popen] = {}
        self.logs: dict[str, object] = {}
        self.proxy = None
        self.monitor: Monitor | None = None
        self.tower_lines: list[str] = []
        self.goal_state = {"n": 0, "total": None, "reached": 0, "last": ""}
        self.t_wall0 = None
        self.sim0 = None
        self.bridge_restarts = 0
        self.view_port = view_port      # None: no live view; 0: any free port
        self.view = None
        if follow_with not in ("bridge", "ardupilot", "both"):
            raise ValueError(f"--follow-with: bridge, ardupilot or both, not {follow_with!r}")
        # who follows the drone: the bridge's tf follow drives rover sysid 2; ArduPilot's FOLLOW
        # (tools/follow_ap.py) drives sysid 2 instead, or a second rover (sysid 3) beside it
        if follow_with != "bridge" and self.family:
            raise ValueError("--follow-with ardupilot|both flies the lab's drone and rover, not a family")
        self.follow_with = follow_with
        self.foll_pos_p = foll_pos_p
        self.ap_follower = {"bridge": None, "ardupilot": ROVER, "both": ROVER + 1}[follow_with]
        self.ap_driver = None

    # -- processes

    def _start(self, name: str, args: list[str]) -> subprocess.Popen:
        log = open(self.dir / f"{name}.log", "a")
        self.logs.setdefault(name, log)
        log.write(f"$ {shlex.join(masked_argv(args))}\n")     # the signing key never in clear
        log.flush()
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        if name == "tower":
            p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                 start_new_session=True, env=env, bufsize=1, preexec_fn=die_with_parent())
            threading.Thread(target=self._read_tower, args=(p, log), daemon=True).start()
        else:
            # stdin: none reads it, and a world started through `ssh -tt` would take the terminal raw
            p = subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, start_new_session=True, env=env,
                                 stdin=subprocess.DEVNULL, preexec_fn=die_with_parent())
        self.procs[name] = p
        return p

    def sitl_cmd(self) -> list[str]:
        h, out = self._world_binds()
        if self.family:
            return self.family_sitl_cmd()
        # the bridge and the tower are the lockstep participants: the world waits for both at t=0
        lock = ("--lockstep", "2") if self.lockstep else ()
        return towerlink_cmd("sitl", "--speedup", speedup_text(self.speedup), "--seed", str(self.seed),
                             "--no-save", "--tcp-base", "0", "--udp-base", "0",
                             "--endpoint", f"0=udpin:{h}:{self.ports['drone']}",
                             "--endpoint", f"1=udpin:{h}:{self.ports['rover']}",
                             "--out", f"udpout:{out}:{self.ports['vehicles']}", *self._scenario_wind(),
                             *lock, *(("--rovers", "2") if self.follow_with == "both" else ()),
                             *self._signing_args(), *self.sitl_args)

    def _signing_args(self) -> list[str]:
        """--signing-key KEY for the world, the bridge and the tower (none without a key)."""
        return [SIGNING_FLAG, self.signing_key] if self.signing_key else []

    def _key(self) -> bytes | None:
        from common.mavlink.signing import key_from_text
        return key_from_text(self.signing_key)

    def _world_binds(self) -> tuple[str, str]:
        """(where the world's endpoints listen, where it pushes its telemetry)."""
        return (self.world.bind, self.world.local) if self.world else (self.host, self.host)

    @property
    def world_addr(self) -> str:
        """Where the bridge (and the van's driver) reach the world's endpoints."""
        return self.world.addr if self.world else self.host

    def _scenario_wind(self) -> list[str]:
        """The scenario's wind table as `sitl --wind` (none when it has no wind)."""
        if not self.scenario:
            return []
        from common.scenario import load_scenario
        w = load_scenario(self.scenario).wind_arg()
        return ["--wind", w] if w else []

    def family_sitl_cmd(self) -> list[str]:
        """Every vehicle of the scenario, vehicle i (sysid i+1) on its own udpin port."""
        (h, out), sc = self._world_binds(), self.sc
        cmd = towerlink_cmd("sitl", "--drones", str(len(sc.drones)), "--rovers", str(len(sc.rovers)),
                            "--speedup", speedup_text(self.speedup), "--seed", str(self.seed), "--no-save",
                            "--tcp-base", "0", "--udp-base", "0",
                            "--home=" + ",".join(f"{v:.10g}" for v in SITL_HOME),   # "=": it starts with "-"
                            "--out", f"udpout:{out}:{self.ports['vehicles']}", *self._scenario_wind())
        if self.lockstep:
            # the bridge, the family's one tower link (gcs.tower_link) and the van's driver
            cmd += ["--lockstep", str(2 + (sc.van is not None))]
        for _name, sysid, _kind in sc.vehicles:
            cmd += ["--endpoint", f"{sysid - 1}=udpin:{h}:{self.ports[f'vehicle{sysid}']}"]
        if sc.van is not None:
            i = sc.van.sysid - 1
            cmd += ["--endpoint", f"{i}=udpin:{h}:{self.ports['van_driver']}",
                    "--mission", f"{i}={self.write_van_mission()}"]
        return cmd + self._signing_args() + list(self.sitl_args)

    def write_van_mission(self) -> Path:
        """The van's route as a QGC WPL 110 mission, looped with DO_JUMP (world NED -> lat/lon)."""
        from common.geo import ned_to_lla
        from common.wpl import WplItem, write
        van = self.sc.van
        items = [WplItem(0, 1, 0, 16, 0, 0, 0, 0, SITL_HOME[0], SITL_HOME[1], SITL_HOME[2]),
                 WplItem(1, 0, 3, 178, 1, van.speed, -1, 0, 0, 0, 0)]      # DO_CHANGE_SPEED ground
        for x, y in van.route:
            lat, lon, _alt = ned_to_lla(SITL_HOME, (x, y, 0.0))
            items.append(WplItem(len(items), 0, 3, 16, 0, 0, 0, 0, lat, lon, 0.0))
        items.append(WplItem(len(items), 0, 3, 177, 2, -1, 0, 0, 0, 0, 0))  # DO_JUMP to 2, forever
        path = self.dir / "van.waypoints"
        write(str(path), items)
        return path

    def drive_van(self) -> None:
        """The van's driver: AUTO and arm on its own link, then keep the link read (van.log)."""
        from gcs.client import Client, ClientError
        van = self.sc.van
        with open(self.dir / "van.log", "a") as f:
            def log(msg: str) -> None:
                f.write(f"van: {msg}\n")
                f.flush()
            try:
                # with lockstep a participant for the van alone, on the van's own endpoint
                # (compid 200: the world tells it from the tower's link)
                with Client.connect(f"udpout:{self.world_addr}:{self.ports['van_driver']}", log=log,
                                    source_component=200, lockstep=self.lockstep,
                                    lockstep_target=van.sysid, signing_key=self._key()) as c:
                    c.wait_heartbeat(van.sysid, timeout=60)
                    c.set_mode("AUTO", van.sysid, timeout=30)
                    c.arm(van.sysid, timeout=60)
                    log(f"AUTO and armed at t={c.sim_time(van.sysid):.2f} s: driving its route "
                        f"at {van.speed:g} m/s")
                    while not self._van_stop.is_set():
                        c.poll(0.2)
            except (ClientError, OSError) as exc:
                log(f"could not start the van: {exc}")

    def bridge_cmd(self) -> list[str]:
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
        if self.follow_with == "ardupilot":
            cmd += ["--no-follow"]          # the rover follows in its own FOLLOW mode
        if self.signing_key:                # the vehicles sign too: the bridge checks them as well
            cmd += [*self._signing_args(), "--vehicle-signing"]
        return cmd + list(self.bridge_args)

    def node_cmd(self, path: Path) -> list[str]:
        frame = self.follow_frame or _scenario_follow(self.scenario)
        return [sys.executable, str(path), "--connect", f"udpout:{self.host}:{self.ports['nodes']}",
                "--follow-frame", frame]

    def tower_url(self) -> str:
        port = self.ports["proxy"] if self.tower_loss > 0 else self.ports["tower"]
        return f"udpout:{self.host}:{port}"

    def tower_cmd(self) -> list[str]:
        cmd = towerlink_cmd("tower", "--connect", self.tower_url(),
                            "--result", str(self.dir / "tower.json"), "--tlog", str(self.dir / "tower.tlog"),
                            "--goal-timeout", f"{self.goal_timeout:g}")
        if self.lockstep:
            cmd.append("--lockstep")
        for flag, v in (("--scenario", self.scenario), ("--goals", self.goals), ("--alt", self.alt),
                        ("--radius", self.radius), ("--finish", self.finish)):
            if v is not None:
                cmd.append(f"{flag}={v}")  # '=': goals may start with '-'
        return cmd + self._signing_args() + list(self.tower_args)

    def _read_tower(self, p: subprocess.Popen, log) -> None:
        import re
        for line in p.stdout:
            log.write(line)
            log.flush()
            line = line.rstrip("\n")
            self.tower_lines.append(line)
            m = re.search(r"goal (\d+)/(\d+) (sent|reached|FAILED)", line)
            if m:
                n, total, what = int(m.group(1)), int(m.group(2)), m.group(3)
                self.goal_state.update(n=n, total=total, last=what)
                if what == "reached":
                    self.goal_state["reached"] = n
                    self.goal_state["count"] = self.goal_state.get("count", 0) + 1
            g = re.search(r"goal \d+/\d+ sent: \w+ \[([^\]]+)\] at t=([-\d.]+) s", line)
            if g and self.view is not None:
                try:
                    p = tuple(float(v) for v in g.group(1).split(","))
                    self.view.goal(float(g.group(2)), (p + (0.0, 0.0, 0.0))[:3])
                except ValueError:
                    pass
            if self.echo:
                print(f"  {line}", flush=True)

    def start(self) -> None:
        """World, monitor, bridge, (loss proxy), tower: in that order."""
        self.t_wall0 = time.monotonic()
        self.monitor = Monitor(self.dir, {"vehicles": self.ports["vehicles"], "bridge": self.ports["bridge"]},
                               self.host, {"vehicles": self._world_binds()[1]}, signing_key=self._key())
        if self.view_port is not None:
            from tools.live_view import LiveView
            self.view = LiveView(self.host, self.view_port)
            self.monitor.listeners["bridge"] = self.view.on_message
        if self.ap_follower is not None:
            from common.scenario import load_scenario
            from tools.follow_ap import ApFollowDriver
            self.ap_driver = ApFollowDriver(self.monitor.send_to_vehicle, self.ap_follower, DRONE,
                                            load_scenario(self.scenario).follow_offset, self.foll_pos_p)
            self.monitor.listeners["vehicles"] = self.ap_driver.on_message
        self.monitor.start()
        self.start_world()
        if self.family and self.sc.van is not None:
            self.van_driver = threading.Thread(target=self.drive_van, daemon=True, name="van-driver")
            self.van_driver.start()
        self.start_bridge()
        for path in self.nodes:
            self._start(f"node-{path.stem}", self.node_cmd(path))
        if self.tower_loss > 0:
            from tools.loss_proxy import LossProxy
            from common.mavlink.lockstep import is_lockstep
            self.proxy = LossProxy(self.ports["proxy"], (self.host, self.ports["tower"]),
                                   loss=self.tower_loss, seed=self.loss_seed, host=self.host,
                                   spare=is_lockstep if self.lockstep else None)
            self.proxy.start()
        self._start("tower", self.tower_cmd())
        self.write_meta()

    def world_cmd(self) -> list[str]:
        """The command that starts the world, where it runs (--world-cmd-prefix)."""
        return self.world.command(self.sitl_cmd()) if self.world else self.sitl_cmd()

    def start_world(self) -> None:
        if self.world is not None and self.world.attach:      # the user starts it there
            hint = f"\n  (put your {SIGNING_FLAG} where *** stands)" if self.signing_key else ""
            print(f"towerlink fly: start the world on {self.world.addr}:\n  "
                  f"{shlex.join(masked_argv(self.world_cmd()))}{hint}", flush=True)
            return
        self._start("sitl", self.world_cmd())

    def start_bridge(self) -> subprocess.Popen:
        return self._start("bridge", self.bridge_cmd())

    def kill_bridge(self, sig: int = signal.SIGKILL) -> None:
        """Kill the bridge (SIGKILL by default: no goodbye), e.g. to prove the drone holds."""
        p = self.procs.get("bridge")
        if p is not None and p.poll() is None:
            _signal_group(p, sig)
            p.wait(5)

    def restart_bridge(self) -> subprocess.Popen:
        self.bridge_restarts += 1
        return self.start_bridge()

    def alive(self) -> dict[str, bool]:
        return {k: p.poll() is None for k, p in self.procs.items()}

    def wait(self, timeout: float, progress: float | None = 1.0, out=sys.stdout) -> int | None:
        """Wait for the tower to finish (its exit status), printing progress; None on timeout."""
        end = time.monotonic() + timeout
        last_print = last_params = 0.0
        tower = self.procs["tower"]
        while True:
            rc = tower.poll()
            if rc is not None:
                return rc
            now = time.monotonic()
            for name in ("sitl", *(f"node-{p.stem}" for p in self.nodes)):
                p = self.procs.get(name)
                if p is not None and p.poll() is not None:
                    raise RuntimeError(f"{name} exited with status {p.returncode}; see {self.dir / (name + '.log')}")
            # every 0.5 s until the scoring parameters have come (a short lockstep run at max
            # speed is over in a few wall seconds), then every 2 s
            missing = self.monitor is not None and any(n not in self.monitor.params for n in SCORING_PARAMS)
            if now - last_params > (0.5 if missing else 2.0) and self.monitor is not None:
                last_params = now
                self.monitor.request_params()
            if self.ap_driver is not None:
                self.ap_driver.tick()
            self.achieved_speedup()          # also anchors sim0 for the summary when quiet
            if progress and now - last_print >= progress:
                last_print = now
                print(self.progress_line(), file=out, flush=True)
            if now > end:
                return None
            time.sleep(0.05)

    def achieved_speedup(self) -> float | None:
        if self.monitor is None or self.t_wall0 is None:
            return None
        snap = self.monitor.snapshot()
        if self.sim0 is None and snap["sim"] > 0:
            self.sim0 = (snap["sim"], time.monotonic())
            return None
        if self.sim0 is None:
            return None
        ds, dw = snap["sim"] - self.sim0[0], time.monotonic() - self.sim0[1]
        return ds / dw if dw > 0.5 else None

    def progress_line(self) -> str:
        snap = self.monitor.snapshot() if self.monitor else {"sim": 0, "drone": None, "follow_err": None}
        gs = self.goal_state
        goal = f"goal {gs['n']}/{gs['total']} {gs['last']}" if gs["total"] else "goal -/- (preparing)"
        if self.family:
            total = sum(len(d.goals) for d in self.sc.drones)
            goal = f"goals {gs.get('count', 0)}/{total} reached"
        d = snap["drone"]
        dtxt = f"drone [{d[0]:7.2f}, {d[1]:7.2f}, {d[2]:6.2f}]" if d else "drone [waiting]"
        e = snap["follow_err"]
        etxt = f"rover err {e:5.2f} m" if e is not None else "rover err   -  "
        sp = self.achieved_speedup()
        sptxt = f"{sp:.1f}x" if sp else "-"
        return (f"[fly] t={snap['sim']:7.2f} s sim  {goal:<20} {dtxt}  {etxt}  "
                f"speedup {sptxt} (asked {speedup_text(self.speedup)}x{', lockstep' if self.lockstep else ''})")

    def write_meta(self) -> None:
        meta = {"scenario": self.scenario, "speedup": speedup_text(self.speedup), "lockstep": self.lockstep,
                "seed": self.seed, "signed": bool(self.signing_key),
                "follow_frame": self.follow_frame, "goals": self.goals, "tower_loss": self.tower_loss,
                "follow_with": self.follow_with, "ardupilot_follower": self.ap_follower,
                "ports": self.ports, "world_host": self.world.describe() if self.world else None,
                "commands": {k: shlex.join(masked_argv(v)) for k, v in
                             (("sitl", self.world_cmd()), ("bridge", self.bridge_cmd()), ("tower", self.tower_cmd()),
                              *((f"node-{p.stem}", self.node_cmd(p)) for p in self.nodes))}}
        (self.dir / "meta.json").write_text(json.dumps(meta, indent=2))

    def stop(self) -> None:
        """Stop everything this launch started (tower first, world last); idempotent."""
        order = [("tower", signal.SIGINT), *((f"node-{p.stem}", signal.SIGTERM) for p in self.nodes),
                 ("bridge", signal.SIGTERM), ("sitl", signal.SIGTERM)]
        self._van_stop.set()
        for name, sig in order:
            if name == "bridge" and self.van_driver is not None:
                self.van_driver.join(3.0)   # it leaves the lockstep at its next TICK: the world still runs
            p = self.procs.get(name)
            if p is None:
                continue
            if p.poll() is None:
                _signal_group(p, sig)
                try:
                    p.wait(5)
                except subprocess.TimeoutExpired:
                    _signal_group(p, signal.SIGKILL)
                    p.wait(5)
        self._van_stop.set()
        if self.van_driver is not None:
            self.van_driver.join(3.0)
        if self.proxy is not None:
            self.proxy.stop()
        if self.monitor is not None:
            self.monitor.stop()
        if self.view is not None:
            self.view.stop()
            self.view = None
        for log in self.logs.values():
            try:
                log.close()
            except Exception:  # noqa: BLE001
                pass

    # -- results

    def finish_run(self, tower_rc: int | None) -> dict:
        """After stop(): score, plot, draw the frames; returns the summary dict."""
        from tools.run_summary import format_summary, summarize
        tj = self.dir / "tower.json"
        tower = json.loads(tj.read_text()) if tj.exists() else {"ok": False, "goals": [],
                                                                "error": "the tower wrote no result"}
        meta = {"seed": self.seed, "speedup": self.speedup if math.isfinite(self.speedup) else "max",
                "lockstep": self.lockstep, "signed": bool(self.signing_key),
                "tower_exit": tower_rc,
                "follow_frame": self.follow_frame or _scenario_follow(self.scenario),
                "run_dir": str(self.dir), "bridge_restarts": self.bridge_restarts,
                "tower_loss": self.tower_loss}
        if self.nodes:
            meta["nodes"] = [p.stem for p in self.nodes]
        if self.proxy is not None:
            meta["proxy"] = {"passed": self.proxy.passed, "dropped": self.proxy.dropped}
        if self.sim0 is not None and self.monitor is not None:
            snap = self.monitor.snapshot()
            meta["achieved_speedup"] = (snap["sim"] - self.sim0[0]) / max(1e-6, time.monotonic() - self.sim0[1])
        if self.family:
            from tools.family_summary import format_family_summary, summarize_family
            s = summarize_family(self.dir, tower=tower, scenario_path=self.scenario, meta=meta)
        else:
            s = summarize(self.dir, tower=tower, scenario_path=self.scenario, meta=meta)
        s["ok"] = bool(s["ok"]) and tower_rc == 0
        (self.dir / "summary.json").write_text(json.dumps(s, indent=2, default=_json_default))
        text = format_family_summary(s) if self.family else format_summary(s)
        extras = []
        try:
            from tools.plot_tracks import plot_run
            plot_run(self.dir, scenario=self.scenario)
            extras.append("tracks.png")
        except Exception as exc:  # noqa: BLE001 - a plot failure must not hide the summary
            extras.append(f"(tracks plot failed: {exc})")
        try:
            from tools.view_frames import buffer_from_tlog, write_drawing
            buf, now = buffer_from_tlog(self.dir / "bridge.tlog")
            if buf.edge_stats():
                write_drawing(buf, self.dir / "frames.pdf", now=now, title=f"view_frames: {self.dir.name}")
                write_drawing(buf, self.dir / "frames.png", now=now, title=f"view_frames: {self.dir.name}")
                extras.append("frames.pdf")
        except Exception as exc:  # noqa: BLE001
            extras.append(f"(frames diagram failed: {exc})")
        try:
            from tools.run_mcap import write_run_mcap
            write_run_mcap(self.dir)
            extras.append("run.mcap")
        except Exception as exc:  # noqa: BLE001 - the recording must not hide the summary
            extras.append(f"(run.mcap failed: {exc})")
        files = sorted(p.name for p in self.dir.iterdir())
        text += f"\nrun folder {self.dir}: {' '.join(files)}"
        (self.dir / "summary.txt").write_text(text + "\n")
        s["text"] = text
        return s


def _signal_group(p: subprocess.Popen, sig: int) -> None:
    try:
        os.killpg(p.pid, sig)
    except (ProcessLookupError, PermissionError):
        pass


def _scenario_follow(path: str | None) -> str:
    from common.scenario import load_scenario
    return load_scenario(path).follow_frame


def _json_default(o):
    try:
        import numpy as np
        if isinstance(o, np.generic):
            return o.item()
    except ImportError:  # pragma: no cover
        pass
    return str(o)


# ----------------------------------------------------------------------------- CLI


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", default=None,
                        help="scenario TOML, or a shipped one by name: default, family (3 drones, "
                             "3 rovers), family100 (100 drones in lanes on two layers), van (the tower on "
                             "a moving van); default: the lab scenario")
    parser.add_argument("--speedup", type=speedup_type, default=5.0, metavar="N|max",
                        help="at most N sim seconds per wall second (default 5; the machine may deliver less); "
                             "'max': as fast as the machine and the lockstep participants allow")
    parser.add_argument("--lockstep", action=argparse.BooleanOptionalAction, default=True,
                        help="whole-system lockstep (issue 11; the default): the world waits for the bridge, "
                             "the tower and the van's driver (TOWERLINK_LOCKSTEP), so a seed gives the same "
                             "figures at any --speedup and load. --no-lockstep: the old free-running world; "
                             "the bridge and the tower then lag it by their wall-clock time times the speedup, "
                             "and the figures depend on the machine. Third-party clients see an ordinary "
                             "vehicle either way")
    parser.add_argument("--follow-frame", choices=("drone", "drone_yaw"), default=None,
                        help="frame the rover's goal is written in (default: the scenario's)")
    parser.add_argument("--seed", type=int, default=1, help="the world's noise seed (default 1)")
    parser.add_argument("--goals", default=None, help='override the tower goals: --goals="x,y;x,y;..." (tower frame; use = since they start with -)')
    parser.add_argument("--alt", type=float, default=None, help="mission altitude, m (default: scenario)")
    parser.add_argument("--radius", type=float, default=None, help="goal radius, m (default: scenario)")
    parser.add_argument("--finish", choices=("land", "rtl", "none"), default=None,
                        help="after the goals (default: the scenario's; none leaves the drone hovering)")
    parser.add_argument("--out", default=None, help="run folder (default runs/<timestamp>)")
    parser.add_argument("--timeout", type=float, default=600.0, help="wall seconds for the whole run")
    parser.add_argument("--goal-timeout", type=float, default=120.0, help="wall seconds per goal")
    parser.add_argument("--tower-loss", type=float, default=0.0,
                        help="drop this fraction of the tower link's packets (seeded proxy), e.g. 0.2")
    parser.add_argument("--view", nargs="?", type=int, const=8765, default=None, metavar="PORT",
                        help="serve the run live to Foxglove on ws://127.0.0.1:PORT (default port 8765; "
                             "0 picks a free one; needs towerlink[view]). Every run also writes run.mcap")
    parser.add_argument("--nodes", metavar="DIR", default=None,
                        help="run every DIR/*.py as a tf2_ros node (e.g. examples/lab: the lab's tower_to_map, "
                             "world_to_drone, ground_robot_controller); the bridge only routes (--route-only)")
    parser.add_argument("--follow-with", choices=("bridge", "ardupilot", "both"), default="bridge",
                        help="who makes the rover follow: the bridge's tf follow (default), ArduPilot's own "
                             "FOLLOW mode on the rover (bridge follow off), or both side by side (a second "
                             "rover, sysid 3, in FOLLOW); the summary gives each one's follow error")
    parser.add_argument("--foll-pos-p", type=float, default=None,
                        help="FOLL_POS_P for ArduPilot's follow (default: ArduPilot's 0.1)")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="a vehicle parameter for the world (ArduPilot name, e.g. WPNAV_SPEED=300); "
                             "repeatable; written to RUN/params.parm and passed as sitl --params")
    add_signing_argument(parser, "MAVLink 2 signing for the whole run: {forms}. The world's vehicles, the bridge's tower "
                             "link and the tower (and the van's driver) all sign and accept only signed "
                             "packets, lockstep included. The key is masked (***) in the run folder's logs and "
                             "meta.json (it is still on the processes' command lines). Not with --nodes")
    parser.add_argument("-v", "--verbose", action="store_true", help="echo the tower's log lines")
    from tools import hosts
    hosts.add_arguments(parser)
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")


def run(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out else Path("runs") / time.strftime("%Y%m%d-%H%M%S")
    try:
        from common.scenario import ScenarioError, load_scenario
        load_scenario(args.scenario)
    except ScenarioError as exc:
        print(f"towerlink fly: {exc}", file=sys.stderr)
        return 2
    sitl_args: tuple[str, ...] = ()
    if args.param:      # --param NAME=VALUE: a .parm file of defaults for the world (sitl --params)
        lines = []
        for item in args.param:
            name, _eq, value = item.partition("=")
            try:
                if not name.strip():
                    raise ValueError("no name")
                lines.append(f"{name.strip()} {float(value):.9g}")
            except ValueError:
                print(f"towerlink fly: --param {item!r}: write NAME=VALUE, e.g. WPNAV_SPEED=300", file=sys.stderr)
                return 2
        out.mkdir(parents=True, exist_ok=True)
        (out / "params.parm").write_text("\n".join(lines) + "\n")
        sitl_args = ("--params", str((out / "params.parm").resolve()))
    try:
        from tools import hosts
        world = hosts.from_args(args)
        launch = Launch(out, scenario=args.scenario, speedup=args.speedup, seed=args.seed,
                        follow_frame=args.follow_frame, goals=args.goals, alt=args.alt, radius=args.radius,
                        finish=args.finish, goal_timeout=args.goal_timeout, tower_loss=args.tower_loss,
                        echo=args.verbose, view_port=args.view, nodes=args.nodes,
                        lockstep=args.lockstep, follow_with=args.follow_with, foll_pos_p=args.foll_pos_p,
                        world=world, sitl_args=sitl_args, signing_key=args.signing_key)
    except ValueError as exc:
        print(f"towerlink fly: {exc}", file=sys.stderr)
        return 2
    where = f"bridge + tower on 127.0.0.1, {world.describe()}" if world else "world + bridge + tower on 127.0.0.1"
    print(f"towerlink fly: {where} (ports {launch.ports}); run folder {out}", flush=True)
    if math.isinf(args.speedup) and not args.lockstep:
        print("towerlink fly: --speedup max without --lockstep: the world runs as fast as the CPU and the "
              "bridge and the tower fall behind it; the figures will depend on the machine", file=sys.stderr)

    def on_term(signum, frame):  # SIGTERM: same clean stop as Ctrl-C
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)
    rc: int | None = None
    interrupted = False
    failure = None
    try:
        launch.start()
        if launch.view is not None:
            print(f"towerlink fly: live view for Foxglove at {launch.view.url} "
                  "(Open connection > Foxglove WebSocket; layout: docs/foxglove_layout.json)", flush=True)
        rc = launch.wait(args.timeout, progress=None if args.quiet else 1.0)
        if rc is None:
            failure = f"timed out after {args.timeout:g} s wall"
    except KeyboardInterrupt:
        interrupted = True
        failure = "interrupted"
    except Exception as exc:  # noqa: BLE001 - stop everything, then report
        failure = str(exc)
    finally:
        launch.stop()
        signal.signal(signal.SIGTERM, old)
        if world is not None and world.attach:
            print(f"towerlink fly: the world on {world.addr} is yours to stop (Ctrl-C there)", flush=True)
    if failure:
        print(f"towerlink fly: {failure}; all processes stopped", file=sys.stderr, flush=True)
    try:
        s = launch.finish_run(rc)
        print("\n" + s["text"], flush=True)
    except Exception as exc:  # noqa: BLE001
        print(f"towerlink fly: could not summarise the run: {exc}", file=sys.stderr)
        return 1 if not interrupted else 130
    if interrupted:
        return 130
    return 0 if (rc == 0 and s["ok"]) else 1
