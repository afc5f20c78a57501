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
keeps the frames' authority). In lockstep the nodes take part too (TOWERLINK_NODE_LOCKSTEP=1,
bridge --lockstep-nodes N): each answers the bridge's TICKs after its loop ran on sim time, and
the bridge answers the world only then (bridge.node_lockstep).

While they run it prints a progress line (goal n/N, drone position, rover follow error
from truth, sim time and the speedup achieved) at most once a second, and only when the run
has moved on since the last one. At the end, on
Ctrl-C, or on any failure, every process it started is stopped. Then it writes the
run folder (--out, default runs/<timestamp>):

  vehicles.tlog bridge.tlog tower.tlog   one tlog per link
  tower.json meta.json                   the tower's result; how the run was made
  summary.json summary.txt               the scores (also printed)
  faults.json                            with faults: when each took effect and was cleared
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

Lockstep is the default: the world waits for the bridge, the tower (a family's
one shared link), the van's driver and this launcher's recorder (TOWERLINK_LOCKSTEP), so a seed gives the
same summary figures at any --speedup (max: as fast as the machine allows) and under any CPU
load. --no-lockstep runs the old free-running world (figures then depend on the machine):

  towerlink fly --speedup max            # lockstep, as fast as the machine allows
  towerlink fly family --speedup max
  towerlink fly --no-lockstep            # free-running world

Faults: --tower-loss 0.2 or --tower-link loss=0.1,latency=0.3,down.bandwidth=20000 makes the tower's
link lossy, slow, jittery, narrow for the whole run (tools/link_proxy.py); a scenario's [[faults]]
(common/scenario_faults.py) add a timeline: at sim time t, parameters on a vehicle (SITL's SIM_*
faults, SIM_BATT_VOLTAGE, ...) or the tower link's settings, cleared at `until`. In lockstep each
takes effect at a lockstep frame fixed by its t (a vehicle's fault, like every reaction to a TICK
in the pipelined lockstep, one frame after the first at or after its t), so a seed gives the same
run at any speed and load. The summary lists each fault, the failsafes it caused and when (faults.json holds
when each took effect):

  towerlink fly examples/sweep/faults_lab.toml --param FS_GCS_ENABLE=1 --speedup max

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
import math
import signal
import sys
import time
from pathlib import Path

from common.mavlink.lockstep import speedup_type
from common.mavlink.signing import add_signing_argument
from tools.fly_launch import Launch

# This module is the command line. The run itself: tools/fly_plan.py (the options, ports and
# command lines), tools/fly_launch.py (starting, watching and stopping the processes, with
# fly_processes, fly_monitor, fly_van and fly_progress), tools/fly_run_folder.py (meta.json,
# the summary and the drawings).


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", default=None,
                        help="scenario TOML, or a shipped one by name: default, family (3 drones, "
                             "3 rovers), family100 (100 drones in lanes on two layers), van (the tower on "
                             "a moving van); default: the lab scenario")
    parser.add_argument("--speedup", type=speedup_type, default=5.0, metavar="N|max",
                        help="at most N sim seconds per wall second (default 5; the machine may deliver less); "
                             "'max': as fast as the machine and the lockstep participants allow")
    parser.add_argument("--lockstep", action=argparse.BooleanOptionalAction, default=True,
                        help="whole-system lockstep (the default): the world waits for the bridge, "
                             "the tower and the van's driver (TOWERLINK_LOCKSTEP), so a seed gives the same "
                             "figures at any --speedup and load. --no-lockstep: the old free-running world; "
                             "the bridge and the tower then lag it by their wall-clock time times the speedup, "
                             "and the figures depend on the machine. Third-party clients see an ordinary "
                             "vehicle either way")
    parser.add_argument("--lockstep-pipeline", action=argparse.BooleanOptionalAction, default=True,
                        help="with --lockstep (the default): the world sends each TICK and steps on at once, "
                             "waiting for its ACKs at the next TICK (sitl --lockstep-pipeline), so it steps "
                             "while the bridge, the tower and the monitor work; their reactions take effect "
                             "one lockstep period (40 ms sim) later. Still the same figures at any --speedup "
                             "and load; --no-lockstep-pipeline: the world waits for every ACK before it steps "
                             "on (slower; other figures)")
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
                        help="drop this fraction of the tower link's frames, both ways (seeded proxy), e.g. 0.2")
    parser.add_argument("--tower-link", default=None, metavar="SPEC",
                        help="the tower link's faults for the whole run, e.g. loss=0.1,latency=0.3,jitter=0.1,"
                             "reorder=0.05,duplicate=0.01,bandwidth=20000 (s, bytes/s; sim s in lockstep); a bare name "
                             "sets both directions, up.NAME / down.NAME one. The scenario's [[faults]] come on top")
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
    parser.add_argument("--helpers", action=argparse.BooleanOptionalAction, default=None,
                        help="draw the pictures and record run.mcap in children forked at the start, busy beside "
                             "the flight and each other (default: when this process may use two or more CPUs); "
                             "--no-helpers: all of it here after the flight, from one read of the tlogs (less "
                             "CPU in all: what a sweep wants, whose other runs use the other cores)")


def _helpers(out: Path, scenario: str | None, wanted: bool | None = None) -> tuple:
    """(drawings, recorder): children that draw the run and record run.mcap, started now so they
    do their part while the run flies (tools.fly_drawings, tools.fly_recorder); (None, None)
    where fork is not available, `wanted` is False, or (`wanted` None) this process has one CPU
    (e.g. under taskset: the helpers' work would then only slow the lockstep chain down), and all
    of it is done after the flight."""
    from tools.fly_child import ForkedHelper
    from tools.fly_drawings import DrawingWorker
    from tools.fly_recorder import Recorder
    if not ForkedHelper.available() or wanted is False or (wanted is None and ForkedHelper.cpus() < 2):
        return None, None
    out.mkdir(parents=True, exist_ok=True)
    drawings, recorder = DrawingWorker(out, scenario), Recorder(out)
    drawings.start()        # forked before launch.start() starts any thread
    try:
        recorder.start()
    except BaseException:
        drawings.close()
        raise
    return drawings, recorder


def run(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out else Path("runs") / time.strftime("%Y%m%d-%H%M%S")
    from common.scenario import ScenarioError, load_scenario     # (a Ctrl-C here: exit 130, nothing started)
    try:
        load_scenario(args.scenario)
    except ScenarioError as exc:
        print(f"towerlink fly: {exc}", file=sys.stderr)
        return 2
    sitl_args: tuple[str, ...] = ()
    start_params: dict[str, float] = {}
    if args.param:      # --param NAME=VALUE: a .parm file of defaults for the world (sitl --params)
        lines = []
        for item in args.param:
            name, _eq, value = item.partition("=")
            try:
                if not name.strip():
                    raise ValueError("no name")
                start_params[name.strip()] = float(value)
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
                        tower_link=args.tower_link, start_params=start_params,
                        echo=args.verbose, view_port=args.view, nodes=args.nodes,
                        lockstep=args.lockstep, lockstep_pipeline=args.lockstep_pipeline,
                        follow_with=args.follow_with, foll_pos_p=args.foll_pos_p,
                        world=world, sitl_args=sitl_args, signing_key=args.signing_key)
    except ValueError as exc:
        print(f"towerlink fly: {exc}", file=sys.stderr)
        return 2
    if world is None or not world.attach:
        launch.start_world()    # first: its imports (about a second) overlap everything else here
    try:
        where = f"bridge + tower on 127.0.0.1, {world.describe()}" if world else "world + bridge + tower on 127.0.0.1"
        print(f"towerlink fly: {where} (ports {launch.ports}); run folder {out}", flush=True)
        if math.isinf(args.speedup) and not args.lockstep:
            print("towerlink fly: --speedup max without --lockstep: the world runs as fast as the CPU and the "
                  "bridge and the tower fall behind it; the figures will depend on the machine", file=sys.stderr)
        drawings, recorder = _helpers(out, args.scenario, args.helpers)
    except BaseException:
        launch.stop()           # no world left behind
        raise
    try:
        return _fly(args, launch, world, drawings, recorder)
    finally:
        for helper in (drawings, recorder):
            if helper is not None:
                helper.close()      # also when the run failed or was interrupted: no child left


def _fly(args: argparse.Namespace, launch: Launch, world, drawings, recorder) -> int:
    """Start, watch, stop, summarise; the exit status."""

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
        helpers = [h for h in (drawings, recorder) if h is not None]
        rc = launch.wait(args.timeout, progress=None if args.quiet else 1.0,
                         on_flying=lambda: [h.flight_begins() for h in helpers])
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
        s = launch.finish_run(rc, drawings, recorder, fork=args.helpers)
        print("\n" + s["text"], flush=True)
    except Exception as exc:  # noqa: BLE001
        print(f"towerlink fly: could not summarise the run: {exc}", file=sys.stderr)
        return 1 if not interrupted else 130
    if interrupted:
        return 130
    return 0 if (rc == 0 and s["ok"]) else 1
