"""Checkpoints 2 and 3: the rover follows the drone's ground point through the student's drone frame.

Both read one flight (tools.lab.evidence) and check, in this order:

* the frame: world_to_drone broadcast world -> <frame>, stamped on the drone's clock (each stamp
  is one of the drone's telemetry times, within STAMP_SLACK), at the drone's position;
* the goals: ground_robot_controller sent the rover goals, on the ground (z near 0);
* the follow: the rover's distance from the point under the drone (truth), RMS;
* checkpoint 2: the goals swing with the attitude as the tilting frame does (the wobble);
  checkpoint 3: world -> drone_yaw does not tilt (its wobble under WOBBLE_GONE) and the follow
  error is under 1 m RMS.
"""
from __future__ import annotations

import math

import numpy as np

from tools.lab import hints
from tools.lab.evidence import Evidence
from tools.lab.result import Checkpoint, not_done, not_flown
from tools.lab.submission import Submission
from tools.run_data import DRONE

STAMP_SLACK = 0.2           # s between a transform's stamp and the drone's nearest telemetry time
AT_DRONE = 0.5              # m between the frame's origin and the drone's position at the stamp
ON_GROUND = 2.0             # m: a rover goal's |z| below this is on the ground
CP2_FOLLOW = 5.0            # m RMS: through the tilting frame the rover swings, but it follows
CP3_FOLLOW = 1.0            # m RMS: the lab's mark for the level frame
WOBBLE_GONE = 0.05          # m RMS of the level frame's ground-point swing
SWING_SHARE = 0.5           # checkpoint 2's goals swing at least this share of the frame's wobble

W2D, GRC = "world_to_drone", "ground_robot_controller"


def precheck(sub: Submission, number: int) -> Checkpoint | None:
    """The verdict without a flight (not done, cannot start), or None: fly it."""
    todo = [f"{n}.py" for n in (W2D, GRC) if sub.untouched(n)]
    if todo:
        return not_done(number, f"{' and '.join(todo)} {'is' if len(todo) == 1 else 'are'} still the skeleton")
    broken = [hints.syntax(sub.sources[n]) for n in (W2D, GRC) if sub.sources[n].error]
    if broken:
        return Checkpoint(number, False, "a node does not start", hints=broken)
    return None


def _frame_checks(sub: Submission, ev: Evidence, child: str, cp: Checkpoint) -> bool:
    """world -> child exists, on the drone's clock, at the drone; figures and hints into cp."""
    src = sub.sources[W2D]
    frames = ev.frame(child)
    cp.figures[f"{child}_transforms"] = len(frames)
    if not frames:
        cp.hints.append(hints.never_broadcast(src, child))
        return False
    stamps = np.array([t for t, _ in frames])
    clock = ev.drone_clock()
    if not len(clock):
        return True
    idx = np.clip(np.searchsorted(clock, stamps), 1, len(clock) - 1)
    near = np.minimum(np.abs(stamps - clock[idx - 1]), np.abs(stamps - clock[idx]))
    offset = float(np.median(stamps - clock[idx]))
    cp.figures["stamp_offset_s"] = offset
    if float(np.median(near)) > STAMP_SLACK:
        cp.hints.append(hints.wall_clock_stamp(src, offset))
        return False
    est = ev.data.estimate[DRONE]
    xyz = np.array([v[:3] for _, v in frames])
    err = float(np.median(np.linalg.norm(xyz - est.at(stamps), axis=1)))
    cp.figures["frame_vs_drone_m"] = err
    if err > AT_DRONE:
        cp.hints.append(hints.frame_not_at_drone(src, child, err))
        return False
    return True


def _goal_checks(sub: Submission, ev: Evidence, cp: Checkpoint) -> np.ndarray | None:
    """The rover's goals, on the ground; None (and a hint) when there are none or they are up high."""
    src = sub.sources[GRC]
    goals = ev.rover_goals()
    cp.figures["rover_goals"] = len(goals)
    if not len(goals):
        cp.hints.append(hints.never_drove(src))
        return None
    z = float(np.median(goals[:, 3]))
    cp.figures["rover_goal_z_m"] = z
    if abs(z) > ON_GROUND:
        cp.hints.append(hints.goal_at_drone_height(src, z))
        return None
    return goals


def _swing(ev: Evidence, goals: np.ndarray) -> float:
    """RMS horizontal distance of the rover's goals from the point right under the drone (truth)."""
    tr = ev.data.truth.get(DRONE)
    if tr is None or not len(tr) or not len(goals):
        return float("nan")
    under = tr.at(goals[:, 0])
    return float(np.sqrt(np.mean(np.hypot(goals[:, 1] - under[:, 0], goals[:, 2] - under[:, 1]) ** 2)))


def _crashes(ev: Evidence, cp: Checkpoint) -> bool:
    for node in (W2D, GRC):
        c = ev.crash(node)
        if c is not None:
            cp.hints.append(hints.crashed(node, c))
    return bool(cp.hints)


def judge(sub: Submission, ev: Evidence, number: int) -> Checkpoint:
    """Checkpoint 2 (the flight followed frame drone) or 3 (drone_yaw)."""
    idle = not_flown(number, ev.run)
    if idle is not None and not any(ev.crash(n) for n in (W2D, GRC)):
        return idle
    frame = "drone" if number == 2 else "drone_yaw"
    s = ev.summary
    follow = s.get("follow_error") or {}
    wob = (s.get("wobble") or {}).get("from_transforms", {})
    rms = follow.get("rms")
    cp = Checkpoint(number, False, "", {"flight": ev.run.dir.name, "follow_rms_m": rms, "follow_max_m": follow.get("max"),
                                        "wobble_rms_m": (wob.get(frame) or {}).get("rms"),
                                        "sim_s": ev.run.sim, "wall_s": round(ev.run.wall, 2)})
    frame_ok = not _crashes(ev, cp) and _frame_checks(sub, ev, frame, cp)
    goals = _goal_checks(sub, ev, cp) if frame_ok else None
    swing = _swing(ev, goals) if goals is not None else float("nan")
    cp.figures["goal_swing_m"] = swing
    wobble = cp.figures["wobble_rms_m"]
    parts = [f"follow error RMS {_m(rms)}", f"wobble of {frame} RMS {_m(wobble)}"]
    ok = frame_ok and goals is not None and rms is not None
    if number == 2:
        parts.append(f"goals swing RMS {_m(swing)}")
        if ok and wobble and not swing >= SWING_SHARE * wobble:
            cp.hints.append(hints.goal_not_through_tilt(sub.sources[GRC], frame))
            ok = False
        limit = CP2_FOLLOW
    else:
        if ok and (wobble is None or wobble > WOBBLE_GONE):
            tilt = _tilt_deg(ev.frame(frame))
            cp.hints.append(hints.roll_pitch_kept(sub.sources[W2D], tilt))
            ok = False
        limit = CP3_FOLLOW
    if ok and rms > limit:
        cp.hints.append(hints.rover_far(sub.sources[GRC], rms))
        ok = False
    cp.passed = ok
    cp.measured = ", ".join(parts)
    if not ok and not cp.hints:             # nothing of the student's to blame: say what is missing
        cp.notes.append(f"the flight ended early: {ev.run.failure}" if ev.run.failure else
                        "the flight recorded no follow error (no truth of the drone and the rover)")
    return cp


def _tilt_deg(frames) -> float:
    if not frames:
        return 0.0
    q = np.array([v[3:7] for _, v in frames])
    # tilt of the frame's z axis from the vertical: R[2, 2] = 1 - 2 (qx^2 + qy^2)
    c = np.clip(1 - 2 * (q[:, 0] ** 2 + q[:, 1] ** 2), -1, 1)
    return float(np.degrees(np.max(np.arccos(c))))


def _m(v) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.2f} m"


__all__ = ["judge", "precheck", "not_done"]
