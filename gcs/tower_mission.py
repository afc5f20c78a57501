"""The tower's mission for one drone, on a Client-like link (gcs.client.Client or gcs.tower_link).

:class:`Mission` waits for the drone's heartbeat, sets GUIDED, arms, takes off, sends the goals
one at a time in the goal frame (re-sending the current one every `resend` s of the client's
clock, with the first send's stamp) and lands or returns. A goal is reached when a fresh
LOCAL_POSITION_NED sample is within the radius; in a moving frame (the tower on the van) it is
judged against the goal's world point at its stamp, resolved with :class:`gcs.tower_frames.TowerFrames`.
Results (:class:`MissionResult`, :class:`GoalResult`) are in the goal frame (m, NED) and sim
seconds from the drone's own time_boot_ms. Goal text is parsed by :func:`parse_goals`.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from gcs.tower_frames import TowerFrames

DRONE_SYSID = 1


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
                 log: Callable[[str], None] = print, frames: TowerFrames | None = None,
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
