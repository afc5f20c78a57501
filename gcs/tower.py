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
sends on its link (gcs.tower_family.TowerFrames, a tf2 TransformListener in small): the goal's
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
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING

from common.mavlink.signing import add_signing_argument

if TYPE_CHECKING:
    from gcs.tower_family import TowerFrames

DEFAULT_CONNECT = "udpout:127.0.0.1:14600"
DRONE_SYSID = 1


# ----------------------------------------------------------------------------- pure parts


def parse_goals(text: str, altitude: float) -> list[tuple[float, float, float]]:
    """Parse "x,y;x,y[,z];..." into goals (z defaults to -altitude, down)."""
    goals = []
    for k, item in enumerate(p for p in text.replace("\n", ";").split(";") if p.strip()):
        parts = [v for v in item.replace(" ", ",").split(",") if v]
        if len(parts) not in (2, 3):
            raise ValueError(f"goal {k + 1} {item.strip()!r}: want x,y or x,y,z")
        try:
            vals = [float(v) for v in parts]
        except ValueError:
            raise ValueError(f"goal {k + 1} {item.strip()!r}: not numbers") from None
        if not all(math.isfinite(v) for v in vals):
            raise ValueError(f"goal {k + 1} {item.strip()!r}: not finite")
        goals.append((vals[0], vals[1], vals[2] if len(vals) == 3 else -altitude))
    if not goals:
        raise ValueError("no goals given")
    return goals


def format_goals(goals: Sequence[Sequence[float]]) -> str:
    """The inverse of parse_goals (x,y,z;...), for passing goals on a command line."""
    return ";".join(",".join(f"{v:.6g}" for v in g) for g in goals)


@dataclass
class GoalResult:
    """One goal of the mission, as the tower saw it (tower frame, sim seconds)."""
    index: int                         # 1-based
    goal: tuple[float, float, float]   # tower frame
    frame: str = "tower"
    sent_sim: float | None = None      # drone time_boot_ms / 1000 when first sent
    reached_sim: float | None = None   # stamp of the first sample within the radius
    reached: bool = False
    distance: float | None = None      # at the reaching sample, or last seen on failure
    position: tuple[float, float, float] | None = None
    sends: int = 0
    wall_s: float | None = None
    error: str | None = None
    world: tuple[float, float, float] | None = None   # resolved at the stamp (moving tower only)
    latest_offset: float | None = None   # m: the same goal resolved with the latest transform when
                                         # reached lands this far from `world` (moving tower only)

    @property
    def time_to_reach(self) -> float | None:
        if self.reached_sim is None or self.sent_sim is None:
            return None
        return self.reached_sim - self.sent_sim


@dataclass
class MissionResult:
    ok: bool = False
    goals: list[GoalResult] = field(default_factory=list)
    takeoff_sim: float | None = None     # sim time when the height was reached
    takeoff_position: tuple[float, float, float] | None = None  # goal frame, at that time
    start_sim: float | None = None       # sim time when the mission began (armed)
    end_sim: float | None = None         # sim time at the end (landed or failed)
    finish: str = "land"
    finished: bool = False               # the land/rtl completed
    altitude: float = 0.0
    radius: float = 0.0
    error: str | None = None

    def to_json(self) -> dict:
        d = asdict(self)
        for g, gd in zip(self.goals, d["goals"]):
            gd["time_to_reach"] = g.time_to_reach
        return d


class Mission:
    """The tower's sequence on a Client-like object (gcs.client.Client, or a test double).

    Needs: wait_heartbeat, set_mode, arm, takeoff, goto / goto_named, wait_reached,
    land, rtl, sim_time, position, system(sysid).
    """

    def __init__(self, client, goals: Sequence[Sequence[float]], *, altitude: float,
                 radius: float, finish: str = "land", frame: str = "tower",
                 goal_timeout: float = 120.0, resend: float = 1.0, sysid: int = DRONE_SYSID,
                 connect_timeout: float = 60.0, arm_timeout: float = 60.0,
                 log: Callable[[str], None] = print, frames: "TowerFrames | None" = None,
                 before_takeoff: Callable[[], None] | None = None,
                 after_takeoff: Callable[[], None] | None = None) -> None:
        if finish not in ("land", "rtl", "none"):
            raise ValueError(f"finish must be land, rtl or none, not {finish!r}")
        self.c = client
        self.goals = [tuple(float(v) for v in g) for g in goals]
        self.altitude = altitude
        self.radius = radius
        self.finish = finish
        self.frame = frame
        self.goal_timeout = goal_timeout
        self.resend = resend
        self.sysid = sysid
        self.connect_timeout = connect_timeout
        self.arm_timeout = arm_timeout
        self.log = log
        self.frames = frames
        self.before_takeoff = before_takeoff
        self.after_takeoff = after_takeoff
        self.result = MissionResult(finish=finish, altitude=altitude, radius=radius,
                                    goals=[GoalResult(i + 1, g, frame) for i, g in enumerate(self.goals)])

    def send_goal(self, g: GoalResult) -> None:
        x, y, z = g.goal
        ms = int(round(g.sent_sim * 1000)) if g.sent_sim is not None else None   # the first send's stamp
        if self.frame == "tower":   # the tower link's own frame: plain SET_POSITION_TARGET_LOCAL_NED
            self.c.goto(x, y, z, self.sysid, time_boot_ms=ms)
        else:
            self.c.goto_named(self.frame, x, y, z, self.sysid, time_boot_ms=ms)
        g.sends += 1

    def run(self) -> MissionResult:
        r = self.result
        try:
            self._prepare()
            for g in r.goals:
                if not self._fly_to(g):
                    break
            r.ok = all(g.reached for g in r.goals)
            self._finish()
        except KeyboardInterrupt:
            r.error = "interrupted"
            raise
        except Exception as exc:  # noqa: BLE001 - every client error ends the mission, reported
            r.error = f"{type(exc).__name__}: {exc}"
            self.log(f"mission failed: {r.error}")
            r.ok = all(g.reached for g in r.goals)  # a failed landing after the goals is logged
            if r.takeoff_sim is not None and not r.finished:
                try:
                    self._finish()
                except Exception as exc2:  # noqa: BLE001
                    self.log(f"{self.finish} failed too: {exc2}")
        r.end_sim = self.c.sim_time(self.sysid)
        return r

    def _prepare(self) -> None:
        r, c, s = self.result, self.c, self.sysid
        self.log(f"waiting for the drone (system {s}) ...")
        c.wait_heartbeat(s, timeout=self.connect_timeout)
        st = c.system(s)
        self.log(f"drone: heartbeat, mode {st.mode_name}, {'armed' if st.armed else 'disarmed'}")
        c.set_mode("GUIDED", s, timeout=self.arm_timeout)
        self.log("mode GUIDED")
        if self.before_takeoff is not None:
            # wait here, disarmed: an armed copter left on the ground disarms itself (DISARM_DELAY)
            self.before_takeoff()
        c.arm(s, timeout=self.arm_timeout)
        r.start_sim = c.sim_time(s)
        self.log(f"armed at t={r.start_sim:.2f} s (sim)")
        try:
            p = c.takeoff(self.altitude, s, timeout=self.goal_timeout,
                          tolerance=max(self.radius, 0.3))
        finally:
            if self.after_takeoff is not None:
                self.after_takeoff()
        r.takeoff_sim = p.t
        r.takeoff_position = p.xyz
        self.log(f"takeoff: {self.altitude:g} m reached at t={p.t:.2f} s "
                 f"({self.frame} [{p.x:.2f}, {p.y:.2f}, {p.z:.2f}])")

    def _fly_to(self, g: GoalResult) -> bool:
        n = len(self.goals)
        c = self.c
        g.sent_sim = c.sim_time(self.sysid)
        after_ms = int(round(g.sent_sim * 1000))
        self.send_goal(g)
        self.log(f"goal {g.index}/{n} sent: {self.frame} {_fmt(g.goal)} at t={g.sent_sim:.2f} s")
        t0 = time.monotonic()
        moving = self.frames is not None and self.frames.moving(self.frame)
        try:
            if moving:
                hit = self._wait_reached_moving(g, after_ms)
            else:
                hit = c.wait_reached(g.goal, self.radius, self.goal_timeout, sysid=self.sysid,
                                     resend=lambda: self.send_goal(g), resend_interval=self.resend,
                                     after_ms=after_ms)
        except Exception as exc:  # GoalTimeout and friends
            g.error = str(exc)
            g.distance = getattr(exc, "distance", None)
            g.wall_s = time.monotonic() - t0
            self.log(f"goal {g.index}/{n} FAILED: {exc}")
            return False
        g.wall_s = time.monotonic() - t0
        g.reached = True
        g.reached_sim = hit.position.t
        g.distance = hit.distance
        g.position = hit.position.xyz
        extra = ""
        if moving and g.world is not None:
            g.latest_offset = self.frames.latest_offset(self.frame, g.goal, g.world)
            extra = (f"; world {_fmt(g.world)} resolved at its stamp, the latest transform would "
                     f"put it {_f(g.latest_offset)} m away")
        self.log(f"goal {g.index}/{n} reached: {self.frame} {_fmt(g.goal)} in "
                 f"{g.time_to_reach:.2f} s sim (at t={g.reached_sim:.2f} s, "
                 f"{g.distance:.2f} m off, {g.sends} sends, {g.wall_s:.1f} s wall){extra}")
        return True

    def _wait_reached_moving(self, g: GoalResult, after_ms: int):
        """wait_reached for a goal in a moving frame: judged against its world point at its stamp."""
        from gcs.client import GoalTimeout, Reached
        c, st = self.c, self.c.system(self.sysid)
        # the client's clock: sim time with --lockstep, so deadline and resends are the data's
        end = c.clock() + self.goal_timeout
        last_resend = c.clock()
        last_seen, dist = None, None
        while True:
            now = c.clock()
            if g.world is None:
                g.world = self.frames.world_point(self.frame, g.goal, g.sent_sim)
            p = st.position
            if g.world is not None and p is not None and p is not last_seen and p.time_boot_ms > after_ms:
                last_seen = p
                here = self.frames.seen_from(self.frame, g.world)   # the goal in the tower frame now
                if here is not None:
                    dist = p.distance_to(here)
                    if dist <= self.radius:
                        return Reached(p, dist)
            if now >= end:
                raise GoalTimeout(g.goal, self.radius, dist, self.goal_timeout)
            if now - last_resend >= self.resend:
                last_resend = now
                self.send_goal(g)
            c.poll(min(0.05, max(0.0, end - now)))

    def _finish(self) -> None:
        if self.finish == "none":
            return
        self.log(f"{self.finish} ...")
        if self.finish == "land":
            self.c.land(self.sysid, timeout=max(60.0, self.goal_timeout))
        else:
            self.c.rtl(self.sysid, timeout=max(120.0, 2 * self.goal_timeout))
        self.result.finished = True
        self.log(f"landed at t={self.c.sim_time(self.sysid):.2f} s")


def _fmt(p: Sequence[float]) -> str:
    return "[" + ", ".join(f"{v:.2f}" for v in p) + "]"


def _f(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


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
                        help="whole-system lockstep (issue 11): join the world's TOWERLINK_LOCKSTEP handshake "
                             "through the bridge (`towerlink bridge --lockstep`, `towerlink sitl --lockstep N`); "
                             "every timeout, retry and --resend then counts sim seconds of the world's TICKs")
    add_signing_argument(parser, "MAVLink 2 signing, for a bridge started with --signing-key: {forms}. Everything the "
                             "tower sends is signed (heartbeats, commands, goals, lockstep ACKs) and only "
                             "packets signed with the key are accepted; give the vehicles the same key "
                             "(`towerlink sitl --signing-key`), since the bridge forwards their packets as "
                             "they come. The key is never logged")


def run(args: argparse.Namespace) -> int:
    from common.scenario import ScenarioError, load_scenario

    from gcs.client import Client, ClientError
    from common.mavlink.signing import key_from_text

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
