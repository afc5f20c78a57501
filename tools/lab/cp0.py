"""Checkpoint 0: the static transform of fly.launch against the lab's seven self-checkpoint rows.

Pure (no flight): the args are parsed as static_transform_publisher's (common.scenario), the
seven world points go through it into the tower frame (common.frames), and each must land
within 0.1 m of the lab's row. The two directions are printed as tf_echo prints them
(tools.static_transform.describe). When a row misses, the args are tried again with each
mistake students make undone (the yaw's sign, degrees, the frames swapped, the inverse's
numbers, z/pitch/roll not zero); a variant that passes names the mistake.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from common.frames import Buffer, InvalidArgumentException, PointStamped, Transform, TransformStamped
from common.scenario import ScenarioError, load_scenario, parse_static_transform
from tools.frames_cmd import LAB_CHECKPOINT
from tools.lab.launch_file import LaunchLine
from tools.lab.result import Checkpoint, Hint, not_done

TOLERANCE = 0.1         # m: a row matches within this (the lab's table is rounded to 0.1)
PARENT, CHILD = "world", "tower"


@dataclass(frozen=True)
class Args:
    """static_transform_publisher's eight values."""
    x: float
    y: float
    z: float
    yaw: float
    pitch: float
    roll: float
    parent: str
    child: str

    @classmethod
    def of(cls, ts: TransformStamped) -> "Args":
        yaw, pitch, roll = ts.transform.yaw_pitch_roll()
        x, y, z = (float(v) for v in ts.transform.translation)
        return cls(x, y, z, yaw, pitch, roll, ts.frame_id, ts.child_frame_id)

    def stamped(self) -> TransformStamped:
        tr = Transform.from_euler(yaw=self.yaw, pitch=self.pitch, roll=self.roll, translation=(self.x, self.y, self.z))
        return TransformStamped(self.parent, self.child, 0.0, tr)

    def text(self) -> str:
        return (f"{self.x:g} {self.y:g} {self.z:g} {self.yaw:g} {self.pitch:g} {self.roll:g} "
                f"{self.parent} {self.child}")


def truth() -> TransformStamped:
    """The lab's world -> tower (the default scenario's static frame)."""
    return next(ts for ts in load_scenario().static_transforms if ts.child_frame_id == CHILD)


def rows(ts: TransformStamped) -> list[tuple[tuple, tuple, tuple, float]] | None:
    """(world xy, the lab's tower xy, this transform's tower xy, error m) per row; None when
    the transform does not join world and tower."""
    buf = Buffer()
    buf.set_transform_static(ts, "student")
    out = []
    for world, expected in LAB_CHECKPOINT:
        try:
            p = buf.transform_point(PointStamped(PARENT, 0.0, (*world, 0.0)), CHILD).point
        except Exception:  # noqa: BLE001 - frames other than world and tower: no rows
            return None
        err = float(math.hypot(p[0] - expected[0], p[1] - expected[1]))
        out.append((world, expected, (float(p[0]), float(p[1])), err))
    return out


def passes(a: Args) -> bool:
    try:
        r = rows(a.stamped())
    except InvalidArgumentException:
        return False
    return r is not None and max(e for *_, e in r) <= TOLERANCE


def _variants(a: Args) -> list[tuple[str, Args]]:
    """(mistake, the args with that mistake undone) for the mistakes students make."""
    flat = replace(a, z=0.0, pitch=0.0, roll=0.0)
    inv = Args.of(TransformStamped(a.parent, a.child, 0.0, a.stamped().transform.inverse()))
    return [
        ("sign", replace(a, yaw=-a.yaw)),
        ("degrees", replace(a, yaw=math.radians(a.yaw))),
        ("degrees+sign", replace(a, yaw=-math.radians(a.yaw))),
        ("swapped", replace(a, parent=a.child, child=a.parent)),
        ("inverse", inv),
        ("flat", flat),
    ]


def diagnose(a: Args, where: Hint) -> list[Hint]:
    """Hints for args that do not pass (`where`: the file and line to name)."""
    true = Args.of(truth())
    found = {name for name, v in _variants(a) if passes(v)}
    reversed_frames = (a.parent, a.child) == (CHILD, PARENT)
    out: list[str] = []
    if {a.parent, a.child} != {PARENT, CHILD}:
        out.append(f"the frames are {a.parent!r} -> {a.child!r}: the lab's are frame_id world (the parent) "
                   f"and child_frame_id tower")
    if reversed_frames and passes(a):
        out.append("the transform is right but written tower -> world (the world's pose in the tower frame); "
                   "the lab asks for frame_id world and child_frame_id tower: the tower's pose in the world")
        return [Hint(where.file, where.line, t) for t in out]
    if reversed_frames and "swapped" in found:
        out.append("parent and child are swapped: frame_id is the parent (world), child_frame_id the child "
                   "(tower). Written tower -> world, your numbers describe the inverse transform")
    elif "inverse" in found or "swapped" in found:
        out.append("these are the numbers of the inverse transform (the world's pose in the tower frame): "
                   "the args want where the tower's origin is in the world and how far the tower frame is "
                   "turned from the world's")
    elif math.hypot(a.x - _inv_xy(true)[0], a.y - _inv_xy(true)[1]) < 1.0:
        out.append("x y is where the world's origin is in the tower frame; static_transform_publisher wants the "
                   "child's origin in the parent: where the tower's origin is in the world")
    if "degrees" in found or "degrees+sign" in found or abs(a.yaw) > 2 * math.pi:
        out.append(f"yaw {a.yaw:g} looks like degrees: static_transform_publisher takes radians "
                   f"(radians = degrees x pi / 180)")
    if "sign" in found or "degrees+sign" in found:
        out.append("the yaw's sign: in NED a positive yaw turns x (north) towards y (east), clockwise seen "
                   "from above; the tower's axes are turned counter-clockwise from the world's")
    if (a.z, a.pitch, a.roll) != (0.0, 0.0, 0.0):
        out.append(f"z, pitch and roll are {a.z:g}, {a.pitch:g}, {a.roll:g}: they must be 0 in this 2-D lab")
    if not out:
        out.append("the rows do not match: check the translation (the tower's origin in world, x north, "
                   "y east) and the yaw (radians, clockwise-positive in NED) against your derivation from the table")
    return [Hint(where.file, where.line, t) for t in out]


def _inv_xy(true: Args) -> tuple[float, float]:
    t = true.stamped().transform.inverse().translation
    return float(t[0]), float(t[1])


def judge(launch: LaunchLine) -> Checkpoint:
    """Checkpoint 0 from the launch file's static transform."""
    where = Hint(launch.path.name, launch.line, "")
    if launch.args is None:
        if launch.not_done:
            return not_done(0, f"{launch.where}: {launch.problem}")
        return Checkpoint(0, False, "cannot read the static transform", notes=[launch.problem or ""],
                          hints=[Hint(where.file, where.line, launch.problem or "")])
    try:
        ts = parse_static_transform(launch.args)
    except (ScenarioError, InvalidArgumentException) as exc:
        return Checkpoint(0, False, "the args do not parse", notes=[str(exc)],
                          hints=[Hint(where.file, where.line, f"args=\"{launch.args}\": {exc}")])
    from tools.static_transform import describe
    a = Args.of(ts) if len(launch.args.split()) == 9 else _args_as_given(launch.args)
    r = rows(ts)
    figures = {"args": launch.args, "parent": ts.frame_id, "child": ts.child_frame_id}
    details = "```\n" + describe(ts) + "\n```\n"
    if r is None:
        return Checkpoint(0, False, f"frames {ts.frame_id} -> {ts.child_frame_id} do not join world and tower",
                          figures, hints=diagnose(a, where), details=details)
    worst = max(e for *_, e in r)
    n_ok = sum(e <= TOLERANCE for *_, e in r)
    figures.update({"rows": [{"world": list(w), "lab": list(x), "yours": [round(v, 3) for v in y], "error": e}
                             for w, x, y, e in r], "rows_ok": n_ok, "worst_error": worst})
    details += _table(r)
    ok = n_ok == len(r) and ts.frame_id == PARENT and ts.child_frame_id == CHILD
    measured = f"{n_ok}/{len(r)} rows within {TOLERANCE:g} m (worst {worst:.2f} m); {both_ways(ts)}"
    hints = [] if ok else diagnose(a, where)
    return Checkpoint(0, ok, measured, figures, hints=hints, details=details)


def both_ways(ts: TransformStamped) -> str:
    """tf_echo both ways, in short: translation and yaw of parent->child and child->parent."""
    def one(a: str, b: str, tr: Transform) -> str:
        t = tr.translation
        return f"tf_echo {a} {b}: [{t[0]:.2f}, {t[1]:.2f}, {t[2]:.2f}] yaw {math.degrees(tr.yaw_pitch_roll()[0]):.1f} deg"
    return (f"{one(ts.frame_id, ts.child_frame_id, ts.transform)}, "
            f"{one(ts.child_frame_id, ts.frame_id, ts.transform.inverse())}")


def _args_as_given(text: str) -> Args:
    """The eight values as written (not round-tripped through a quaternion: a yaw of 30 stays 30)."""
    *nums, parent, child = text.split()
    x, y, z, yaw, pitch, roll = (float(v) for v in nums)
    return Args(x, y, z, yaw, pitch, roll, parent, child)


def _table(r) -> str:
    lines = ["| world [x, y] | the lab's tower [x, y] | yours | error m |", "|---|---|---|---|"]
    for w, x, y, e in r:
        mark = "" if e <= TOLERANCE else " **x**"
        lines.append(f"| {list(w)} | {list(x)} | [{y[0]:.1f}, {y[1]:.1f}] | {e:.2f}{mark} |")
    return "\n".join(lines) + "\n"


__all__ = ["judge", "diagnose", "rows", "passes", "truth", "Args", "TOLERANCE"]
