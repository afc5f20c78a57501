"""Checkpoint 1: the drone reaches the tower's three goals, through tower_to_map and fly.launch's transform.

Judged on truth: a goal is reached when the drone's true position came within REACH m of the
goal's world point (the tower's own judgement goes through the student's transform, so it
cannot be trusted here). When it misses, the first goal the drone was given is compared with
what each mistake would have sent: the tower's coordinates untouched, the goal through the
inverse transform (lookup_transform the wrong way round), the goal through a wrong static
transform (checkpoint 0's mistake).
"""
from __future__ import annotations

import numpy as np

from common.frames import Buffer
from common.scenario import parse_static_transform
from tools.lab import hints
from tools.lab.evidence import Evidence
from tools.lab.flights import lab_goals
from tools.lab.result import Checkpoint, Hint, not_done, not_flown
from tools.lab.submission import NODES, Submission

REACH = 0.75        # m: the tower's radius (0.5 m, on the estimate) and a margin for truth
SAME = 0.5          # m: a goal the drone was given "is" a prediction within this

NODE = "tower_to_map"


def static_transforms(args: str) -> tuple:
    """(world <- tower, tower <- world) Transforms of static_transform_publisher args."""
    buf = Buffer()
    buf.set_transform_static(parse_static_transform(args), "student")
    return (buf.lookup_transform("world", "tower").transform, buf.lookup_transform("tower", "world").transform)


def precheck(sub: Submission, cp0: Checkpoint) -> Checkpoint | None:
    """The verdict without a flight (not done, cannot run), or None: fly it."""
    if sub.untouched(NODE):
        return not_done(1, f"{NODE}.py is still the skeleton")
    broken = [hints.syntax(sub.sources[n]) for n in NODES if sub.sources[n].error]
    if broken:          # the flight runs all three: one that cannot start stops it
        return Checkpoint(1, False, "a node does not start", hints=broken)
    if sub.launch.args is None:
        return not_done(1, "it flies your static transform, and fly.launch has none yet (checkpoint 0)")
    if "args" not in cp0.figures:               # there but it does not parse
        return Checkpoint(1, False, "cannot fly: fly.launch's static transform does not parse",
                          hints=list(cp0.hints))
    return None


def judge(sub: Submission, ev: Evidence) -> Checkpoint:
    idle = not_flown(1, ev.run)
    if idle is not None and not any(ev.crash(n) for n in NODES):
        return idle
    world, tower = lab_goals()
    closest = [ev.closest(g) for g in world]
    reached = [c is not None and c <= REACH for c in closest]
    given = ev.drone_goals()
    figures = {"reached": reached, "closest_m": closest, "goals_world": [list(g) for g in world],
               "drone_goals": given[:, 1:4].round(3).tolist(), "flight": ev.run.dir.name,
               "sim_s": ev.run.sim, "wall_s": round(ev.run.wall, 2)}
    n = sum(reached)
    worst = max((c for c in closest if c is not None), default=None)
    measured = f"{n}/{len(world)} goals reached" + (f" (farthest miss {worst:.2f} m)" if worst is not None else "")
    ok = n == len(world)
    cp = Checkpoint(1, ok, measured, figures)
    if ok:
        return cp
    src = sub.sources[NODE]
    crash = ev.crash(NODE)
    ended = [(n, c) for n, c in ((n, ev.crash(n)) for n in NODES if n != NODE) if c is not None and c.stopped]
    if crash is not None:
        cp.hints.append(hints.crashed(NODE, crash))
    elif ended:                             # another node stopped, and the flight with it
        cp.hints += [hints.crashed(n, c) for n, c in ended]
    elif not len(given):
        cp.hints.append(hints.never_sent_goal(src))
    else:
        cp.hints += _why_off(sub, given[0, 1:4], np.array(tower[0]), np.array(world[0]))
    if ev.run.failure and crash is None:
        cp.notes.append(f"the flight ended early: {ev.run.failure}")
    elif not cp.hints:
        cp.notes.append("the drone was given the lab's goals but did not reach them all")
    return cp


def _why_off(sub: Submission, got, tower_goal, world_goal) -> list[Hint]:
    src = sub.sources[NODE]
    if np.linalg.norm(got - world_goal) <= SAME:
        return []                                   # sent right; the miss is elsewhere (a crash, a timeout)
    if np.linalg.norm(got - tower_goal) <= SAME:
        return [hints.not_transformed(src)]
    to_world, to_tower = static_transforms(sub.launch.args)
    if np.linalg.norm(got - to_tower.apply_point(tower_goal)) <= SAME:
        return [hints.lookup_direction(src, "world", "tower", "the tower's goal")]
    if np.linalg.norm(got - to_world.apply_point(tower_goal)) <= SAME:
        return [hints.static_transform_off(sub.launch.path.name, sub.launch.line, got, world_goal)]
    return [hints.goal_off(src, got, world_goal)]
