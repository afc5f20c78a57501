"""towerlink bridge: route MAVLink between the tower and the vehicles, translate frames,
publish the frame tree, and drive the rover to follow the drone.

  towerlink bridge [--tower udpin:127.0.0.1:14600]
                   [--drone udpout:127.0.0.1:14560] [--rover udpout:127.0.0.1:14570]
                   [--out udpout:127.0.0.1:14610 ...] [--scenario FILE]
                   [--follow-frame drone|drone_yaw] [--follow-offset=X,Y] [--no-follow]

Links. The vehicles are reached with pymavlink connection strings (udpout to the
world's UDP ports 14560/14570, or tcp:127.0.0.1:5760/5770). The tower GCS connects to
--tower (default udpin:127.0.0.1:14600; the tower uses udpout:127.0.0.1:14600).
Each --out is an extra GCS-side endpoint in the WORLD frame (no translation) that gets
all vehicle traffic, the transform stream and the bridge's status; `towerlink tf-echo
--connect udpin:127.0.0.1:14610` listens to `--out udpout:127.0.0.1:14610`.

Routing (mavlink-router semantics). Vehicle messages go to the tower and the outs;
GCS messages go to the vehicle named by target_system (all links for 0). Source
sysid/compid/seq are preserved: packets are forwarded as received, and the few that
are translated are re-encoded with the sender's ids. Malformed input (garbage, bad
CRC, truncated, unknown ids) is counted per link and dropped.

Frames. The buffer holds the scenario's static frames, statics added live
(TOWERLINK_STATIC_TRANSFORM, e.g. `towerlink static-transform --publish`), each vehicle's
origin world->drone_origin / world->rover_origin (static, from the vehicle's
GPS_GLOBAL_ORIGIN: a real vehicle's local NED is centred where it booted; world is
--world-origin, else the drone's origin; asked with REQUEST_MESSAGE until known), and
drone_origin->drone, rover_origin->rover (body FRD, from LOCAL_POSITION_NED +
ATTITUDE_QUATERNION paired by time_boot_ms and stamped time_boot_ms/1000) with
drone_origin->drone_yaw / rover_origin->rover_yaw (yaw-only). On the tower link
SET_POSITION_TARGET_LOCAL_NED (LOCAL_NED or LOCAL_OFFSET_NED) is mapped tower->the
target's <name>_origin, LOCAL_POSITION_NED and POSITION_TARGET_LOCAL_NED <name>_origin->tower. TOWERLINK_POSITION_TARGET names its frame.
A goal whose transform is missing (or whose dynamic chain is older than
--max-transform-age) waits and is retried every tick; it is never sent with a guess.
Every transform is published as TOWERLINK_TRANSFORM (statics at 1 Hz wall, dynamic at
the telemetry rate thinned by --tf-rate) to the tower and the outs.

One timeline. A vehicle may run in its own process or on its own host, with a boot clock
of its own. The bridge learns each vehicle's clock offset from its SYSTEM_TIME
(time_unix_usec/1e6 - time_boot_ms/1000: a towerlink world's start in unix time) and maps
every stamp onto the clock of the first vehicle seen (stamp + offset - reference offset)
before it enters the buffer, the follow logic and the stream; vehicles of one world have
one offset, so their stamps are unchanged. Until a vehicle's timeline is known its samples
are held back (the bridge asks for SYSTEM_TIME); after --time-grace wall seconds without
one it is taken to share the reference's world. TIMESYNC (tc1=0, ts1=bridge clock) probes
each vehicle link at 1 Hz to log its round trip: link latency, as in ArduPilot/PX4
companion setups, not used to align clocks.

Follow. At --follow-rate sim Hz the rover (sysid 2) gets SET_POSITION_TARGET_LOCAL_NED
(LOCAL_NED, z 0, drone velocity as feed-forward) = the ground point under the drone
written in --follow-frame as (offset_x, offset_y, +height) and transformed to world.
The bridge puts the rover in GUIDED and arms it. If the drone's telemetry stops for
--follow-timeout sim seconds (judged on the rover's clock, or on wall time x
--speedup when the rover is silent too) the rover is put in HOLD; following resumes
when telemetry returns. Each tick sends TOWERLINK_FOLLOW_STATUS with the ground point
through both frames and the attitude-free reference (the wobble figure).

Trust. A TOWERLINK_STATIC_TRANSFORM (e.g. `towerlink static-transform --publish`) moves
every later tower goal, so it is accepted only from a sysid given with --trust-sysid
(default 255, the tower GCS), never for a frame the bridge owns (world, drone, rover and
their _yaw frames), and not for a frame the scenario defined unless --allow-redefine.
With --signing-key the tower link takes only MAVLink 2 packets signed with that key
(unsigned, wrong key, replayed or stale ones are counted and dropped) and the bridge signs
what it sends. Vehicle packets are forwarded as they arrive: give the vehicles the same
key (`towerlink sitl --signing-key`) so a signing GCS accepts them too, and add
--vehicle-signing so the bridge takes only signed packets from the vehicles as well (it
signs what it translates from them: without the check a forged vehicle packet would reach
the tower signed). `towerlink fly --signing-key` does all of that. A refusal is
answered with STATUSTEXT "static tf refused: <reason>" and counted
(TOWERLINK_BRIDGE_STATUS.refused).

Peers. A udpin link (the tower's, by default) sends to every peer that wrote to it: a
peer silent for 30 s (wall) is dropped, at most 64 are kept (the most recent), and a
peer is added only by a datagram holding a valid MAVLink packet that, with
--signing-key, passed the signature check.

Nodes. --nodes URL opens a world-frame link for tf2_ros-style nodes (common.tf2_ros; the lab's
three nodes in examples/lab). A node's TOWERLINK_TRANSFORM (dynamic, or static with the
flag) is judged like a static frame over the wire (trust, signing, the bridge's and the
scenario's frames), then by authority: the first trusted publisher (sysid/compid) of a
child frame owns it, and a second one is refused, STATUSTEXT "tf refused: 'camera'
belongs to node:255/40", and counted. Accepted frames go into the buffer and out on the
stream, so tf-echo, view-frames and the tlogs show them with their rates. With
--route-only the bridge stops doing the nodes' work: no world->drone/rover frames of its
own, no follow, and the tower's SET_POSITION_TARGET_LOCAL_NED (tower frame) goes, as
received, to the node link, where the lab's tower_to_map turns it into a world goal.
Telemetry to the tower is still mapped world -> tower (the tower's link is in its frame).

A family. With --vehicle SYSID=URL (repeatable) the bridge serves the
scenario's vehicles instead of --drone/--rover: each is named by the scenario (drone1,
rover1, van, ...; frames <name> and <name>_yaw), and every rover a scenario drone names
follows that drone (one follower per pair, each at --follow-rate, in its own drone's
--follow-frame). Goals are routed by target_system, one waiting goal per drone.
A goal whose frame hangs on a moving vehicle (the tower on the van) and whose
time_boot_ms is set is resolved at that stamp, tf2's time travel
lookup_transform_full(world, t, frame, t, fixed=world): where the tower pointed when
it spoke. A re-sent goal with the same stamp gets the same world point.

Give negative offsets with '=': --follow-offset=-2,0 (2 m behind).
"""
from __future__ import annotations

import argparse
import math
import signal
import sys

from common.mavlink.signing import add_signing_argument
from common.mavlink.lockstep import speedup_type


def _offset(text: str) -> tuple[float, float]:
    try:
        x, y = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"offset must be X,Y in metres, got {text!r}") from None
    return x, y


def _vehicle_url(text: str) -> tuple[int, str]:
    sysid, sep, url = text.partition("=")
    try:
        n = int(sysid)
    except ValueError:
        n = 0
    if not sep or not url or not 1 <= n <= 255:
        raise argparse.ArgumentTypeError(f"want SYSID=URL with SYSID 1..255, got {text!r}")
    return n, url


def _url_or_none(text: str) -> str | None:
    return None if text.lower() in ("none", "off", "") else text


def add_arguments(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("links")
    g.add_argument("--tower", default="udpin:127.0.0.1:14600",
                   help="tower GCS endpoint, tower frame (default %(default)s)")
    g.add_argument("--drone", type=_url_or_none, default="udpout:127.0.0.1:14560",
                   help="drone endpoint (default %(default)s; 'none' to disable)")
    g.add_argument("--rover", type=_url_or_none, default="udpout:127.0.0.1:14570",
                   help="rover endpoint (default %(default)s; 'none' to disable)")
    g.add_argument("--out", action="append", default=[], metavar="URL",
                   help="extra world-frame GCS-side endpoint (repeatable), e.g. udpout:127.0.0.1:14610")
    g.add_argument("--world-origin", type=_lla, default=None, metavar="LAT,LON,ALT",
                   help="where world is (deg, deg, m AMSL); default: the drone's EKF origin (GPS_GLOBAL_ORIGIN)")
    g.add_argument("--vehicle", action="append", default=[], metavar="SYSID=URL", type=_vehicle_url,
                   help="serve the scenario's vehicle SYSID at URL (repeatable); replaces --drone/--rover, "
                        "e.g. --vehicle 1=udpout:127.0.0.1:14560 --vehicle 4=udpout:127.0.0.1:14590")
    g.add_argument("--drone-sysid", type=int, default=1)
    g.add_argument("--rover-sysid", type=int, default=2)
    g.add_argument("--sysid", type=int, default=250, help="the bridge's own sysid (default %(default)s)")
    g.add_argument("--compid", type=int, default=191, help="the bridge's compid (default %(default)s)")
    t = p.add_argument_group("trust")
    t.add_argument("--trust-sysid", type=int, action="append", default=None, metavar="SYSID",
                   help="sysid allowed to add static frames over the wire (repeatable; default 255, "
                        "the tower GCS)")
    t.add_argument("--allow-redefine", action="store_true",
                   help="let a trusted sender redefine a frame the scenario defined")
    add_signing_argument(t, "MAVLink 2 signing on the tower link: {forms}; unsigned packets are dropped "
                   "and only signed senders become peers")
    t.add_argument("--vehicle-signing", action="store_true",
                   help="with --signing-key, the vehicle links too take only packets signed with the key "
                        "(vehicles started with `towerlink sitl --signing-key`; others are counted and "
                        "dropped). Without it the bridge trusts its vehicle links: it forwards their "
                        "packets as they come and signs what it translates from them")
    f = p.add_argument_group("frames")
    f.add_argument("--scenario", default=None, help="scenario TOML (default: the built-in lab scenario)")
    f.add_argument("--tower-frame", default="tower", help="frame of the tower link (default %(default)s)")
    f.add_argument("--static", action="append", default=[], metavar="'X Y Z YAW PITCH ROLL PARENT CHILD'",
                   help="extra static transform, static_transform_publisher syntax (repeatable)")
    f.add_argument("--tf-rate", type=float, default=20.0, help="dynamic transform stream thinning, sim Hz: a paired sample closer than half a period "
                        "to the last published one is skipped (default %(default)s)")
    f.add_argument("--telemetry-rate", type=float, default=20.0,
                   help="LOCAL_POSITION_NED/ATTITUDE_QUATERNION rate requested from the vehicles, sim Hz "
                        "(0: do not request)")
    f.add_argument("--cache-time", type=float, default=10.0, help="dynamic edge window, s")
    f.add_argument("--max-transform-age", type=float, default=0.5,
                   help="a dynamic chain older than this (sim s) is not used for goals")
    f.add_argument("--time-grace", type=float, default=1.5,
                   help="wall s to hold a vehicle's samples waiting for its SYSTEM_TIME before "
                        "taking it to share the first vehicle's clock (default %(default)s)")
    n = p.add_argument_group("nodes (tf2_ros over MAVLink: common.tf2_ros, examples/lab)")
    n.add_argument("--nodes", type=_url_or_none, default=None, metavar="URL",
                   help="world-frame link for nodes, e.g. udpin:127.0.0.1:14620: they get what an --out "
                        "gets, and the TOWERLINK_TRANSFORMs they send (from trusted sysids) are stored and "
                        "republished; the first node to publish a frame owns it")
    n.add_argument("--route-only", action="store_true",
                   help="the nodes do the lab's work: the bridge publishes no vehicle frames, does not "
                        "follow, and routes the tower's goals (tower frame, untranslated) to the nodes")
    n.add_argument("--lockstep-nodes", type=int, default=0, metavar="N",
                   help="with --lockstep: wait (at most 15 s wall) for N nodes to join before the first "
                        "barrier; nodes that join (common.tf2_ros with lockstep on) are waited for at every "
                        "barrier, so their reactions take effect at a sim time the data fixes")
    w = p.add_argument_group("rover follow")
    w.add_argument("--no-follow", dest="follow", action="store_false", help="do not drive the rover")
    w.add_argument("--follow-frame", choices=("drone", "drone_yaw"), default=None,
                   help="drone (checkpoint 2, full attitude) or drone_yaw (checkpoint 3); default: scenario")
    w.add_argument("--follow-offset", type=_offset, default=None, metavar="X,Y",
                   help="offset in the yaw-only drone frame, m (behind = negative x); default: scenario")
    w.add_argument("--follow-rate", type=float, default=None, help="follow ticks per sim second (>= 10)")
    w.add_argument("--follow-timeout", type=float, default=1.0,
                   help="sim s without drone telemetry before the rover holds (default %(default)s)")
    w.add_argument("--no-follow-ff", dest="follow_ff", action="store_false",
                   help="no velocity feed-forward in rover targets")
    w.add_argument("--speedup", type=speedup_type, default=1.0, metavar="N|max",
                   help="world speedup, only for the wall-clock fallback of the follow timeout")
    p.add_argument("--lockstep", action="store_true",
                   help="whole-system lockstep: join the world's TOWERLINK_LOCKSTEP handshake "
                        "(with `towerlink sitl --lockstep N`); goal retries and the follower's checks and "
                        "retries then run on the world's TICKs (sim time), and the tower may join through it")
    p.add_argument("--view", nargs="?", type=int, const=8765, default=None, metavar="PORT",
                   help="serve the bridge's stream live to Foxglove on ws://127.0.0.1:PORT (default port "
                        "8765): the bridge pushes its stream to one more out on loopback and a `towerlink view` "
                        "process serves it, so the bridge's own loop pays one sendto per packet and no more "
                        "(needs towerlink[view])")
    p.add_argument("-q", "--quiet", action="store_true", help="no log lines on stderr")
    p.add_argument("--duration", type=float, default=None, help="stop after this many wall seconds")


def config_from_args(args):
    from common.mavlink.ids import TOWER_SYSID
    from bridge.config import BridgeConfig
    from common.mavlink.signing import key_from_text
    from common.scenario import load_scenario, parse_static_transform

    if getattr(args, "vehicle_signing", False) and not args.signing_key:
        raise ValueError("--vehicle-signing needs --signing-key (the key the vehicles sign with)")
    sc = load_scenario(args.scenario)
    statics = list(sc.static_transforms) + [parse_static_transform(s) for s in args.static]
    vehicles, pairs = [], []
    if args.vehicle:
        names = {sysid: name for name, sysid, _kind in sc.vehicles}
        vehicles = [(names.get(sysid, f"vehicle{sysid}"), url, sysid) for sysid, url in args.vehicle]
        given = {sysid for sysid, _url in args.vehicle}
        pairs = [(d, r) for d, r in sc.pairs if d in given and r in given]
    return BridgeConfig(
        vehicles=vehicles, pairs=pairs,
        tower=args.tower, drone=args.drone, rover=args.rover, outs=list(args.out),
        drone_sysid=args.drone_sysid, rover_sysid=args.rover_sysid, sysid=args.sysid,
        compid=args.compid, tower_frame=args.tower_frame, statics=statics, world_origin=args.world_origin,
        follow=args.follow,
        follow_frame=args.follow_frame or sc.follow_frame,
        follow_offset=tuple(args.follow_offset) if args.follow_offset is not None else tuple(sc.follow_offset),
        follow_rate=max(args.follow_rate or sc.follow_rate_hz, 1.0),
        follow_timeout=args.follow_timeout, follow_ff=args.follow_ff, speedup=args.speedup,
        telemetry_rate=args.telemetry_rate, tf_rate=args.tf_rate, cache_time=args.cache_time,
        max_transform_age=args.max_transform_age, time_grace=args.time_grace, quiet=args.quiet,
        trust_sysids=tuple(args.trust_sysid) if args.trust_sysid else (TOWER_SYSID,),
        allow_redefine=args.allow_redefine, signing_key=key_from_text(args.signing_key),
        vehicle_signing=args.vehicle_signing,
        nodes=args.nodes, route_only=args.route_only,
        lockstep=args.lockstep, lockstep_nodes=max(0, args.lockstep_nodes))


def _lla(text: str) -> tuple[float, float, float]:
    try:
        lat, lon, alt = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LAT,LON,ALT, got {text!r}") from None
    if not (abs(lat) <= 90 and abs(lon) <= 180 and math.isfinite(alt)):
        raise argparse.ArgumentTypeError(f"not a place: {text!r}")
    return (lat, lon, alt)


def start_viewer(port: int) -> tuple[str, object]:
    """A `towerlink view` child process on a free loopback UDP port; returns (out url, process).
    A separate process keeps the viewer's work (and its imports) out of the bridge's loop."""
    import socket
    import subprocess
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        udp = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "view", "--connect", f"udpin:127.0.0.1:{udp}",
                             "--port", str(port)])   # same process group: a kill of the bridge's group takes it too
    return f"udpout:127.0.0.1:{udp}", proc


def run(args) -> int:
    viewer = None
    if args.view is not None:
        url, viewer = start_viewer(args.view)
        args.out = list(args.out) + [url]
    try:
        return _run(args)
    finally:
        if viewer is not None:
            viewer.terminate()
            try:
                viewer.wait(5)
            except Exception:  # noqa: BLE001 - never leave it behind
                viewer.kill()


def _run(args) -> int:
    from bridge.loop import Bridge

    try:
        cfg = config_from_args(args)
        bridge = Bridge(cfg)
    except (ValueError, OSError) as exc:
        print(f"towerlink bridge: {exc}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, bridge.stop)
    signal.signal(signal.SIGINT, bridge.stop)
    served = (", ".join(f"{n} (sysid {s}) {u}" for n, s, u in ((n, s, u) for n, u, s in cfg.vehicles))
              if cfg.vehicles else f"drone {cfg.drone}; rover {cfg.rover}")
    bridge.log(f"tower {cfg.tower} ({cfg.tower_frame} frame); {served}; "
               f"outs {cfg.outs or '-'}; follow {'off' if not cfg.follow else cfg.follow_frame} "
               f"offset {cfg.follow_offset}; frames {[ts.child_frame_id for ts in cfg.statics]}")
    from common.collector import tune_for_long_run
    tune_for_long_run()       # a Packet per datagram, 66,000 /s with 1,000 vehicles (common/collector.py)
    try:
        bridge.run(args.duration)
    finally:
        if not cfg.quiet:
            print(bridge.summary(), file=sys.stderr, flush=True)
        bridge.close()
    return 0
