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

Parameters: ArduPilot names. --params FILE gives defaults ("NAME VALUE" lines, as SITL's
--defaults); every PARAM_SET is saved to STATE_DIR/drone<j>.parm or rover<j>.parm and loaded
on the next start (as SITL's eeprom.bin). FS_GCS_ENABLE defaults to 0 (off), as ArduPilot.

Examples:
  towerlink sitl                                  # drone + rover on the default ports
  towerlink sitl --drones 2 --rovers 0 --speedup 5
  towerlink sitl --endpoint 0=udpin:127.0.0.1:20000 --out udpout:127.0.0.1:14550
  towerlink sitl --mission 0=survey.waypoints       # vehicle 0 starts with this mission

Lockstep (issue 11): with --lockstep N the world waits at t=0 for N participants (towerlink
bridge --lockstep, towerlink tower --lockstep through it) and never steps past a TOWERLINK_LOCKSTEP
TICK until each has ACKed it; one silent for --lockstep-timeout wall seconds is dropped. Other
clients see an ordinary vehicle. --speedup max then runs as fast as the slowest participant allows:
  towerlink sitl --lockstep 2 --speedup max

Missions, fences and rally points uploaded by a GCS are saved beside the parameters
(STATE_DIR/drone<j>.missions.json) and loaded on the next start. --mission I=FILE loads a
QGC WPL 110 file (as written by QGroundControl, Mission Planner, MAVProxy 'wp save') into
vehicle I's mission at start, replacing the saved one.
"""
from __future__ import annotations

import argparse
import asyncio
import signal
import sys

from gcs.signing import key_from_text as signing_key
from vehicle.world import DEFAULT_HOME, DEFAULT_STATE_DIR, World, WorldConfig


def _speedup(s: str) -> float:
    from gcs.lockstep import speedup_arg
    try:
        return speedup_arg(s)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e))


def _home(s: str) -> tuple[float, float, float]:
    try:
        lat, lon, alt = (float(x) for x in s.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError("expected LAT,LON,ALT")
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise argparse.ArgumentTypeError("latitude/longitude out of range")
    return lat, lon, alt


def _endpoint(s: str) -> tuple[int, str]:
    from vehicle.link import parse_endpoint
    try:
        i, spec = s.split("=", 1)
        parse_endpoint(spec)
        return int(i), spec
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected INDEX=udpin:HOST:PORT (or udpout/tcpin): {e}")


def _out(s: str) -> str:
    from vehicle.link import parse_endpoint
    try:
        parse_endpoint(s)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e))
    return s


def _mission(s: str):
    """I=FILE -> (I, [MissionItem]); a file that cannot be read or an item that an upload
    would refuse is an argparse error naming it."""
    from gcs import wpl
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


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--drones", type=int, default=1, metavar="N", help="number of drones (default 1)")
    p.add_argument("--rovers", type=int, default=1, metavar="M", help="number of rovers (default 1)")
    p.add_argument("--speedup", type=_speedup, default=1.0, metavar="N|max",
                   help="at most N sim seconds per wall second (default 1); 'max': as fast as the CPU "
                        "and the --lockstep participants allow")
    p.add_argument("--lockstep", type=int, default=0, metavar="N",
                   help="whole-system lockstep (issue 11): wait at t=0 until N participants (bridge, "
                        "tower) sent TOWERLINK_LOCKSTEP JOIN on every vehicle, then never step past a "
                        "TICK until every participant ACKed it; participants reach the world over its UDP "
                        "endpoints (default 0: off)")
    p.add_argument("--lockstep-period", type=float, default=0.04, metavar="S",
                   help="sim seconds between lockstep TICKs (default 0.04; rounded to the 50 Hz autopilot tick)")
    p.add_argument("--lockstep-timeout", type=float, default=10.0, metavar="S",
                   help="wall seconds a participant may stay silent before it is dropped (default 10)")
    p.add_argument("--rate", type=float, default=400.0, metavar="HZ", help="physics rate (default 400)")
    p.add_argument("--home", type=_home, default=DEFAULT_HOME, metavar="LAT,LON,ALT",
                   help="world origin = home (default %s,%s,%s, ArduPilot SITL's)" % DEFAULT_HOME)
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--params", metavar="FILE", help="parameter defaults, ArduPilot .parm format")
    p.add_argument("--state-dir", default=DEFAULT_STATE_DIR,
                   help=f"where saved parameters, missions, fences and rally points live (default {DEFAULT_STATE_DIR})")
    p.add_argument("--no-save", action="store_true", help="do not load or save parameters or missions in the state dir")
    p.add_argument("--out", action="append", default=[], type=_out, metavar="udpout:HOST:PORT",
                   help="extra endpoint for every vehicle (repeatable)")
    p.add_argument("--endpoint", action="append", default=[], type=_endpoint, metavar="I=SPEC",
                   help="endpoint for vehicle I; replaces its defaults (repeatable)")
    p.add_argument("--mission", action="append", default=[], type=_mission, metavar="I=FILE",
                   help="QGC WPL 110 file loaded into vehicle I's mission at start (repeatable)")
    p.add_argument("--host", default="127.0.0.1", help="address of the default endpoints (default 127.0.0.1)")
    p.add_argument("--base-port", "--tcp-base", dest="tcp_base", type=int, default=5760,
                   help="TCP port of vehicle 0, +10 per vehicle (default 5760; 0: none)")
    p.add_argument("--udp-base", type=int, default=14560,
                   help="UDP port of vehicle 0, +10 per vehicle (default 14560; 0: none)")
    p.add_argument("--sysid-base", type=int, default=1, help="sysid of vehicle 0 (default 1)")
    p.add_argument("--signing-key", metavar="PASSPHRASE|HEX64",
                   help="MAVLink 2 signing: 64 hex digits, or a passphrase hashed with SHA-256 "
                        "(as MAVProxy's 'signing setup'); unsigned packets are then dropped")


def config_from_args(a: argparse.Namespace) -> WorldConfig:
    endpoints: dict[int, list[str]] = {}
    for i, spec in a.endpoint:
        endpoints.setdefault(i, []).append(spec)
    return WorldConfig(drones=a.drones, rovers=a.rovers, speedup=a.speedup, rate=a.rate, home=a.home,
                       seed=a.seed, params_file=a.params, state_dir=None if a.no_save else a.state_dir,
                       tcp_base=a.tcp_base or None, udp_base=a.udp_base or None, host=a.host,
                       outs=list(a.out), endpoints=endpoints, sysid_base=a.sysid_base,
                       signing_key=signing_key(a.signing_key), missions=dict(a.mission),
                       lockstep=a.lockstep, lockstep_period=a.lockstep_period,
                       lockstep_timeout=a.lockstep_timeout)


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
    n = args.drones + args.rovers
    bad = [i for i, _ in args.mission if i >= n]
    if bad:
        print(f"towerlink sitl: --mission {bad[0]}=...: there are only {n} vehicles (0..{n - 1})", file=sys.stderr)
        return 2
    from vehicle.autopilot.params import ParamFileError
    try:
        world = World(config_from_args(args))
    except (OSError, ParamFileError) as e:      # an unreadable --params FILE
        print(f"towerlink sitl: {e}", file=sys.stderr)
        return 1

    async def main() -> None:
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, world.request_stop)
        await world.run(started=lambda: print(world.banner(), flush=True))

    try:
        asyncio.run(main())
    except OSError as e:
        print(f"towerlink sitl: {e}", file=sys.stderr)
        return 1
    print(world.stats_line(), flush=True)
    return 0
