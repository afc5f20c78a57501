"""The tower: a ground station that thinks in its own frame.

It connects to the bridge's tower link, where positions are in the tower frame
(the bridge translates LOCAL_POSITION_NED world -> tower on the way back and
position targets tower -> world on the way in), and flies the lab mission:

  1. wait for the drone's heartbeat (sysid 1)
  2. set GUIDED, arm (PreArm: texts from the vehicle are printed while it retries)
  3. NAV_TAKEOFF to the scenario altitude (9 m in the lab) and wait to reach it
  4. send the goals one at a time, in tower coordinates; re-send the current goal
     every --resend seconds (the link may lose packets); a goal is reached when a
     fresh LOCAL_POSITION_NED sample (tower frame) is within --radius of it
  5. land (or --finish rtl)

Each goal is logged with its tower coordinates and its time to reach in sim
seconds, from the drone's own time_boot_ms (the wall clock is used only for the
per-goal deadline and the re-send period; with --lockstep those count sim seconds too,
taken from the world's TICKs). Exit status 0 iff every goal was reached.

A goal is stamped with the drone's time when it is first sent and re-sent with that
same stamp. When the tower's frame moves (the tower on the van), the bridge resolves it
in world at that stamp; the tower does the same with the transform stream the bridge
sends on its link (gcs.tower_frames.TowerFrames, a tf2 TransformListener in small): the goal's
world point is lookup_transform_full(world, t, tower, stamp, fixed=world) applied to it,
and a sample (tower frame, latest transform) counts as reached when it is within the
radius of that world point seen from the tower now. Each goal also records how far the
same tower coordinates would land with the latest transform when it was reached
(``latest_offset``).

A family (a scenario with [[drones]], see common.scenario; run by gcs.tower_family): one Mission per drone,
each in its own thread with its own queue, all on one link to the bridge (gcs.tower_link: one
reader, so 100 drones' telemetry is decoded once; with --lockstep the link is the tower's one
participant). They take off one altitude layer at a time from the highest down (a layer
climbs only once every drone of the layer above holds its height, so no climb passes another
drone closer than the layer spacing), then fly at once. A separation watch measures the 3-D
distance between airborne drones (above 1 m, neighbours on a grid) and logs when it drops
below the scenario's min_separation.

Examples:
  towerlink tower                                   # default scenario, bridge at udpout:127.0.0.1:14600
  towerlink tower --goals="-131.04,73.52;-105.06,88.52" --radius 0.5 --finish rtl
  towerlink tower --connect udpout:127.0.0.1:15600 --result out/tower.json --tlog out/tower.tlog
  towerlink tower --scenario family                 # every drone of the family at once (gcs.tower_family)
  towerlink tower --signing-key "my passphrase"      # a bridge (and vehicles) started with the same key
"""
from __future__ import annotations

import argparse
import json
import sys

from common.mavlink.signing import add_signing_argument
from gcs.tower_mission import DRONE_SYSID, Mission, parse_goals

DEFAULT_CONNECT = "udpout:127.0.0.1:14600"


# ----------------------------------------------------------------------------- CLI


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--connect", default=DEFAULT_CONNECT,
                        help=f"the bridge's tower link (pymavlink spelling; default {DEFAULT_CONNECT})")
    parser.add_argument("--scenario", default=None,
                        help="scenario TOML (default: the built-in lab scenario)")
    parser.add_argument("--goals", default=None,
                        help='override the goals: --goals="x,y;x,y[,z];..." in the goal frame (z down, '
                             'default -altitude; use = since they start with -)')
    parser.add_argument("--frame", default=None,
                        help="frame the goals are written in (default: the scenario's goal_frame, "
                             "'tower'); any other frame is sent as a named-frame goal")
    parser.add_argument("--alt", type=float, default=None,
                        help="takeoff altitude, m (default: the scenario's, 9 m in the lab); "
                             "also the goals' height unless they give z")
    parser.add_argument("--radius", type=float, default=None,
                        help="a goal is reached within this distance, m (default: the scenario's)")
    parser.add_argument("--finish", choices=("land", "rtl", "none"), default=None,
                        help="what to do after the last goal (default: the scenario's)")
    parser.add_argument("--goal-timeout", type=float, default=120.0,
                        help="wall seconds allowed per goal (and for takeoff); default 120")
    parser.add_argument("--connect-timeout", type=float, default=60.0,
                        help="wall seconds to wait for the drone's heartbeat and to arm")
    parser.add_argument("--resend", type=float, default=1.0,
                        help="re-send the current goal every N wall seconds (default 1)")
    parser.add_argument("--sysid", type=int, default=DRONE_SYSID, help="the drone's system id")
    parser.add_argument("--result", default=None, help="write the mission result as JSON here")
    parser.add_argument("--tlog", default=None, help="record this link (both ways) as a tlog")
    parser.add_argument("--lockstep", action="store_true",
                        help="whole-system lockstep: join the world's TOWERLINK_LOCKSTEP handshake "
                             "through the bridge (`towerlink bridge --lockstep`, `towerlink sitl --lockstep N`); "
                             "every timeout, retry and --resend then counts sim seconds of the world's TICKs")
    add_signing_argument(parser, "MAVLink 2 signing, for a bridge started with --signing-key: {forms}. Everything the "
                             "tower sends is signed (heartbeats, commands, goals, lockstep ACKs) and only "
                             "packets signed with the key are accepted; give the vehicles the same key "
                             "(`towerlink sitl --signing-key`), since the bridge forwards their packets as "
                             "they come. The key is never logged")


def run(args: argparse.Namespace) -> int:
    from common.mavlink.signing import key_from_text
    from common.scenario import ScenarioError, load_scenario
    from gcs.client import Client, ClientError

    def log(msg: str) -> None:
        print(f"tower: {msg}", flush=True)

    try:
        sc = load_scenario(args.scenario)
    except ScenarioError as exc:
        print(f"tower: {exc}", file=sys.stderr)
        return 2
    altitude = args.alt if args.alt is not None else sc.altitude
    radius = args.radius if args.radius is not None else sc.radius
    finish = args.finish or sc.finish
    frame = args.frame or sc.goal_frame
    try:
        if args.goals:
            goals = parse_goals(args.goals, altitude)
        elif args.alt is not None:
            goals = [(x, y, -altitude if abs(z + sc.altitude) < 1e-9 else z) for x, y, z in sc.goals]
        else:
            goals = list(sc.goals)
    except ValueError as exc:
        print(f"tower: --goals: {exc}", file=sys.stderr)
        return 2
    if sc.is_family and not args.goals:
        from gcs.tower_family import run_family
        return run_family(args, sc, radius=radius, finish=finish, frame=frame)
    if not goals:
        print("tower: the scenario has no goals", file=sys.stderr)
        return 2
    log(f"scenario {sc.name}: {len(goals)} goals in frame {frame!r}, altitude {altitude:g} m, "
        f"radius {radius:g} m, finish {finish}; link {args.connect}"
        + (" (signed)" if getattr(args, "signing_key", None) else ""))
    try:
        client = Client.connect(args.connect, log=log, tlog=args.tlog, lockstep=args.lockstep,
                                signing_key=key_from_text(getattr(args, "signing_key", None)))
    except ClientError as exc:
        log(str(exc))
        return 2
    mission = Mission(client, goals, altitude=altitude, radius=radius, finish=finish, frame=frame,
                      goal_timeout=args.goal_timeout, resend=args.resend, sysid=args.sysid,
                      connect_timeout=args.connect_timeout, arm_timeout=args.connect_timeout,
                      log=log)
    try:
        result = mission.run()
    except KeyboardInterrupt:
        result = mission.result
        result.error = "interrupted"
    finally:
        client.close()
    if args.result:
        with open(args.result, "w") as f:
            json.dump(result.to_json(), f, indent=2)
    if client.signing_report():
        log(client.signing_report())
    reached = sum(g.reached for g in result.goals)
    log(f"{'MISSION OK' if result.ok else 'MISSION FAILED'}: {reached}/{len(goals)} goals reached"
        + (f" ({result.error})" if result.error else ""))
    return 0 if result.ok else (130 if result.error == "interrupted" else 1)
