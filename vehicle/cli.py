"""Start the SITL world: ArduPilot-compatible drones and rovers over MAVLink 2.

By default one drone (sysid 1, MAV_TYPE_QUADROTOR, ArduCopter mode numbers) and one rover
(sysid 2, MAV_TYPE_GROUND_ROVER, ArduRover mode numbers) share one sim clock.

Endpoints (pymavlink connection strings), for vehicle i (drones first, then rovers):
  tcpin:127.0.0.1:{5760+10*i}    TCP server like ArduPilot SITL (several clients)
  udpin:127.0.0.1:{14560+10*i}   UDP: send it a valid MAVLink packet and the vehicle streams to you;
                                 a UDP peer silent for 30 s (wall time) is dropped, at most 64 peers
                                 (the most recently heard) per endpoint; with --signing-key only
                                 a correctly signed packet makes a peer
  --out udpout:HOST:PORT          push every vehicle's stream (e.g. 14550 GCS, 14540 MAVSDK)
so: mavproxy.py --master tcp:127.0.0.1:5760, or mavutil.mavlink_connection('udpout:127.0.0.1:14560').
While the world loads (about a second) every vehicle already sends a HEARTBEAT once a second
on its udpout pushes (--out), with system_status MAV_STATE_BOOT, as ArduPilot does during its
initialisation; not with --lockstep (vehicle/boot_beacon.py).

Networks and the port rule (any number of vehicles, every one reachable):
  A MAVLink network holds 254 vehicles (255 is the GCS's), so vehicle i is in network
  g = i // 254 (--group-size) with sysid 1 + i % 254 (--sysid-base): 1..N for N <= 254.
  Each network has its own --out: --out udpout:HOST:P pushes network g to HOST:P+g, so no
  link carries two vehicles with one sysid (network 0 on 14550, network 1 on 14551, ...).
  Ports step by 10 (ArduPilot's 5760+10*i, 14560+10*i) while the TCP and UDP blocks fit
  apart below 65536 (up to 880 vehicles with the default bases); above, they step by 1
  (5760+i, 14560+i: up to 8800 vehicles); beyond that move a base or set it to 0.
  Refused at start, with the reason: one sysid twice in a network or on one udpout target
  (--sysid, a saved SYSID_THISMAV), a port used twice, port blocks that overlap (TCP, UDP,
  the networks' --out ports on this host), ports above 65535.
  The plan is printed at start and written as JSON to STATE_DIR/network_plan.json (and
  --plan-out FILE): per vehicle its index, kind, network, sysid, tcp, udp and endpoints.
  A process runs on one core: --workers K runs the same world (plan, ports, one sim t = 0)
  in K processes, e.g. towerlink sitl --drones 500 --rovers 500 --workers 2.

Parameters: ArduPilot names. --params FILE gives defaults ("NAME VALUE" lines, as SITL's
--defaults); every PARAM_SET is saved to STATE_DIR/drone<j>.parm or rover<j>.parm and loaded
on the next start (as SITL's eeprom.bin). FS_GCS_ENABLE defaults to 0 (off), as ArduPilot.

Examples:
  towerlink sitl                                  # drone + rover on the default ports
  towerlink sitl --drones 2 --rovers 0 --speedup 5
  towerlink sitl --endpoint 0=udpin:127.0.0.1:20000 --out udpout:127.0.0.1:14550
  towerlink sitl --mission 0=survey.waypoints       # vehicle 0 starts with this mission

Wind (as ArduPilot SITL's SIM_WIND_*): --wind SPD,DIR[,TURB] sets one air mass for the world:
speed m/s, the direction it comes FROM in degrees (270 = from the west), turbulence m/s (standard
deviation). Every vehicle's SIM_WIND_* parameters show it, and a PARAM_SET of SIM_WIND_* on any
vehicle changes it. With ArduPilot's default profile (SIM_WIND_T 0) the wind grows as the square
root of height up to SIM_WIND_T_ALT (60 m); SIM_WIND_T 1 blows at full speed at every height.
  towerlink sitl --wind 8,270,1                     # 8 m/s westerly, 1 m/s turbulence

Lockstep: with --lockstep N the world waits at t=0 for N participants (towerlink
bridge --lockstep, towerlink tower --lockstep through it) and never steps past a TOWERLINK_LOCKSTEP
TICK until each has ACKed it; one silent for --lockstep-timeout wall seconds is dropped. Other
clients see an ordinary vehicle. --speedup max then runs as fast as the slowest participant allows:
  towerlink sitl --lockstep 2 --speedup max
With --lockstep-pipeline the world sends TICK(t) and steps on at once, waiting for ACK(t) at the
next TICK: it steps while the participants work, and their reactions take effect one
--lockstep-period later (towerlink fly's default):
  towerlink sitl --lockstep 2 --lockstep-pipeline --speedup max
With --workers K every worker holds for the same participants at the same TICKs (a bridge ACKs a
TICK only once it came on all its vehicle links), so the K processes step as one world; a
participant driving one vehicle on that vehicle's own endpoint names it in its JOIN.

Missions, fences and rally points uploaded by a GCS are saved beside the parameters
(STATE_DIR/drone<j>.missions.json) and loaded on the next start. --mission I=FILE loads a
QGC WPL 110 file (as written by QGroundControl, Mission Planner, MAVProxy 'wp save') into
vehicle I's mission at start, replacing the saved one.
"""
from __future__ import annotations

import argparse
import asyncio
import math
import os
import signal
import sys

from common.collector import tune_for_long_run
from common.mavlink.lockstep import speedup_type
from common.mavlink.signing import add_signing_argument, key_from_text as signing_key
from vehicle.world_config import DEFAULT_HOME, DEFAULT_STATE_DIR, PLAN_FILE, WorldConfig


def _home(s: str) -> tuple[float, float, float]:
    try:
        lat, lon, alt = (float(x) for x in s.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError("expected LAT,LON,ALT")
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise argparse.ArgumentTypeError("latitude/longitude out of range")
    return lat, lon, alt


def _endpoint(s: str) -> tuple[int, str]:
    from vehicle.link.endpoints import parse_endpoint
    try:
        i, spec = s.split("=", 1)
        parse_endpoint(spec)
        return int(i), spec
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected INDEX=udpin:HOST:PORT (or udpout/tcpin): {e}")


def _out(s: str) -> str:
    from vehicle.link.endpoints import parse_endpoint
    try:
        parse_endpoint(s)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e))
    return s


def _sysid(s: str) -> tuple[int, int]:
    i, sep, sid = s.partition("=")
    try:
        if not sep:
            raise ValueError
        return int(i), int(sid)
    except ValueError:
        raise argparse.ArgumentTypeError("expected INDEX=SYSID, e.g. 3=42")


def _mission(s: str):
    """I=FILE -> (I, [MissionItem]); a file that cannot be read or an item that an upload
    would refuse is an argparse error naming it."""
    from common import wpl
    from pymavlink.dialects.v20 import ardupilotmega as mav
    from vehicle.link.mission_items import from_wpl
    i, sep, path = s.partition("=")
    if not sep or not i.strip().isdigit():
        raise argparse.ArgumentTypeError("expected INDEX=FILE (a QGC WPL 110 file)")
    try:
        lines = wpl.read(path)
    except (OSError, ValueError) as e:
        raise argparse.ArgumentTypeError(str(e))
    items = []
    names = {v: e.name for v, e in mav.enums["MAV_MISSION_RESULT"].items()}
    for w in lines:
        result, item = from_wpl(w)
        if item is None:
            raise argparse.ArgumentTypeError(f"{path}: item {w.seq} refused: {names.get(result, result)}")
        items.append(item)
    return int(i), items


def _wind(s: str):
    from vehicle.physics.wind import parse_wind
    try:
        return parse_wind(s)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e))


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--drones", type=int, default=1, metavar="N", help="number of drones (default 1)")
    p.add_argument("--rovers", type=int, default=1, metavar="M", help="number of rovers (default 1)")
    p.add_argument("--speedup", type=speedup_type, default=1.0, metavar="N|max",
                   help="at most N sim seconds per wall second (default 1); 'max': as fast as the CPU "
                        "and the --lockstep participants allow")
    p.add_argument("--lockstep", type=int, default=0, metavar="N",
                   help="whole-system lockstep: wait at t=0 until N participants (bridge, "
                        "tower) sent TOWERLINK_LOCKSTEP JOIN on every vehicle, then never step past a "
                        "TICK until every participant ACKed it; participants reach the world over its UDP "
                        "endpoints (default 0: off)")
    p.add_argument("--lockstep-period", type=float, default=0.04, metavar="S",
                   help="sim seconds between lockstep TICKs (default 0.04; rounded to the 50 Hz autopilot tick)")
    p.add_argument("--lockstep-timeout", type=float, default=10.0, metavar="S",
                   help="wall seconds a participant may stay silent before it is dropped (default 10)")
    p.add_argument("--lockstep-pipeline", action="store_true",
                   help="pipelined lockstep: send TICK(t) and step on at once, waiting for every ACK(t) "
                        "only at the next TICK, so the world steps while the participants work (faster "
                        "on 2+ cores). A participant's reactions to TICK(t) then take effect one "
                        "--lockstep-period later, at t + period instead of t: still fixed by the data "
                        "(same seed, same figures at any speed and load), but not the figures of a "
                        "world without it")
    p.add_argument("--rate", type=float, default=400.0, metavar="HZ", help="physics rate (default 400)")
    p.add_argument("--home", type=_home, default=DEFAULT_HOME, metavar="LAT,LON,ALT",
                   help="world origin = home (default %s,%s,%s, ArduPilot SITL's)" % DEFAULT_HOME)
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--params", metavar="FILE", help="parameter defaults, ArduPilot .parm format")
    p.add_argument("--state-dir", default=DEFAULT_STATE_DIR,
                   help=f"where saved parameters, missions, fences and rally points live (default {DEFAULT_STATE_DIR})")
    p.add_argument("--no-save", action="store_true", help="do not load or save parameters or missions in the state dir")
    p.add_argument("--out", action="append", default=[], type=_out, metavar="udpout:HOST:PORT",
                   help="push every vehicle's stream here; network g (see below) to PORT+g (repeatable)")
    p.add_argument("--endpoint", action="append", default=[], type=_endpoint, metavar="I=SPEC",
                   help="endpoint for vehicle I; replaces its defaults (repeatable)")
    p.add_argument("--mission", action="append", default=[], type=_mission, metavar="I=FILE",
                   help="QGC WPL 110 file loaded into vehicle I's mission at start (repeatable)")
    p.add_argument("--wind", type=_wind, default=None, metavar="SPD,DIR[,TURB]",
                   help="wind: speed m/s, direction it comes from (deg), turbulence m/s "
                        "(default: the SIM_WIND_* parameters, calm)")
    p.add_argument("--host", default="127.0.0.1", help="address of the default endpoints (default 127.0.0.1)")
    p.add_argument("--base-port", "--tcp-base", dest="tcp_base", type=int, default=5760,
                   help="TCP port of vehicle 0, +10 per vehicle, +1 when +10 does not fit (default 5760; 0: none)")
    p.add_argument("--udp-base", type=int, default=14560,
                   help="UDP port of vehicle 0, +10 per vehicle, +1 when +10 does not fit (default 14560; 0: none)")
    p.add_argument("--sysid-base", type=int, default=1, help="sysid of vehicle 0 of each network (default 1)")
    p.add_argument("--sysid", action="append", default=[], type=_sysid, metavar="I=SYSID",
                   help="explicit sysid of vehicle I (repeatable); one sysid twice in a network is refused")
    p.add_argument("--group-size", type=int, default=None, metavar="N",
                   help="vehicles per MAVLink network (default 254, i.e. sysids SYSID_BASE..254)")
    p.add_argument("--plan-out", metavar="FILE",
                   help="also write the network plan (JSON) here; it always goes to STATE_DIR/network_plan.json "
                        "unless --no-save")
    p.add_argument("--workers", type=int, default=1, metavar="K",
                   help="run the world in K processes (one core each; default 1): worker w runs vehicles "
                        "w*N/K..(w+1)*N/K-1 on the same plan and ports, all starting at one instant; "
                        "with --lockstep all held at the same TICKs")
    add_signing_argument(p, "MAVLink 2 signing: {forms}; unsigned packets are then dropped")


def config_from_args(a: argparse.Namespace) -> WorldConfig:
    endpoints: dict[int, list[str]] = {}
    for i, spec in a.endpoint:
        endpoints.setdefault(i, []).append(spec)
    return WorldConfig(drones=a.drones, rovers=a.rovers, speedup=a.speedup, rate=a.rate, home=a.home,
                       seed=a.seed, params_file=a.params, state_dir=None if a.no_save else a.state_dir,
                       tcp_base=a.tcp_base or None, udp_base=a.udp_base or None, host=a.host,
                       outs=list(a.out), endpoints=endpoints, sysid_base=a.sysid_base,
                       signing_key=signing_key(a.signing_key), missions=dict(a.mission),
                       sysids=dict(a.sysid), group_size=a.group_size,
                       wind=getattr(a, "wind", None),
                       lockstep=a.lockstep, lockstep_period=a.lockstep_period,
                       lockstep_timeout=a.lockstep_timeout,
                       lockstep_pipeline=a.lockstep_pipeline)


def run(args: argparse.Namespace) -> int:
    if args.drones < 0 or args.rovers < 0 or args.drones + args.rovers == 0:
        print("towerlink sitl: need at least one vehicle", file=sys.stderr)
        return 2
    if args.speedup <= 0 or args.rate < 50:
        print("towerlink sitl: --speedup must be > 0 and --rate >= 50", file=sys.stderr)
        return 2
    if args.lockstep < 0 or args.lockstep_period <= 0 or args.lockstep_timeout <= 0:
        print("towerlink sitl: --lockstep must be >= 0, --lockstep-period and --lockstep-timeout > 0",
              file=sys.stderr)
        return 2
    if args.lockstep_pipeline and not args.lockstep:
        print("towerlink sitl: --lockstep-pipeline needs --lockstep N", file=sys.stderr)
        return 2
    n = args.drones + args.rovers
    bad = [i for i, _ in args.mission if i >= n]
    if bad:
        print(f"towerlink sitl: --mission {bad[0]}=...: there are only {n} vehicles (0..{n - 1})", file=sys.stderr)
        return 2
    if args.workers < 1:
        print("towerlink sitl: --workers must be >= 1", file=sys.stderr)
        return 2
    if args.workers > 1 and math.isinf(args.speedup) and not args.lockstep:
        # each worker paces itself to the wall clock from one shared t = 0; unpaced and
        # unlocked, each would run at its own CPU's pace and they would not be one world.
        # With --lockstep the participants hold every worker at the same TICKs instead.
        print("towerlink sitl: --workers needs a finite --speedup, or --lockstep "
              "(each worker paces itself to the wall clock, or is held by the participants)", file=sys.stderr)
        return 2
    from vehicle.autopilot.params import ParamFileError
    from vehicle.network_plan import PlanError
    if args.workers > 1:
        return _run_workers(args)
    cfg = config_from_args(args)
    try:
        plan = cfg.network_plan()
    except PlanError as e:                      # sysids / ports that cannot work: nothing started
        print(f"towerlink sitl: refused: {e}", file=sys.stderr)
        return 2
    # HEARTBEATs while the world (the autopilots, their estimator's filterpy and scipy) loads
    from vehicle.boot_beacon import BootBeacon, boot_targets
    beacon = BootBeacon([] if cfg.lockstep else boot_targets(cfg, plan), cfg.signing_key).start()
    try:
        from vehicle.world import World
        world = World(cfg)
    except PlanError as e:                      # a saved SYSID_THISMAV that clashes: nothing started
        print(f"towerlink sitl: refused: {e}", file=sys.stderr)
        return 2
    except (OSError, ParamFileError) as e:      # an unreadable --params FILE
        print(f"towerlink sitl: {e}", file=sys.stderr)
        return 1
    finally:
        beacon.stop()
    try:
        for path in ([os.path.join(args.state_dir, PLAN_FILE)] if not args.no_save else []) + \
                ([args.plan_out] if args.plan_out else []):
            world.write_plan(path)
    except OSError as e:
        print(f"towerlink sitl: cannot write the network plan: {e}", file=sys.stderr)
        return 1

    async def main() -> None:
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, world.request_stop)
        await world.run(started=lambda: print(world.banner(), flush=True))

    tune_for_long_run()         # the vehicles are built; their messages form no cycles
    try:
        asyncio.run(main())
    except OSError as e:
        print(f"towerlink sitl: {e}", file=sys.stderr)
        return 1
    print(world.stats_line(), flush=True)
    return 0


def _run_workers(args: argparse.Namespace) -> int:
    """--workers K: the plan is checked here, then vehicle/workers.py runs the shares."""
    from vehicle import workers
    from vehicle.autopilot.params import ParamFileError
    from vehicle.network_plan import PlanError
    cfg = config_from_args(args)
    try:
        cfg.network_plan()
    except PlanError as e:
        print(f"towerlink sitl: refused: {e}", file=sys.stderr)
        return 2
    paths = ([os.path.join(args.state_dir, PLAN_FILE)] if not args.no_save else []) + \
        ([args.plan_out] if args.plan_out else [])

    worlds: list = []                    # this process's World, once built

    def out(text: str) -> None:
        if text.startswith("towerlink sitl:") and worlds:     # the banner: the plan is final
            for path in paths:                                 # (written before it shows)
                worlds[0].write_plan(path)
        print(text, flush=True)
    try:
        return workers.run(cfg, args.workers, out=out, on_world=worlds.append)
    except PlanError as e:
        print(f"towerlink sitl: refused: {e}", file=sys.stderr)
        return 2
    except (OSError, ParamFileError, RuntimeError) as e:
        print(f"towerlink sitl: {e}", file=sys.stderr)
        return 1
