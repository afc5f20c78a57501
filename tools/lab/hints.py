"""Hints that name the file and the likely line: each mistake's explanation, placed by reading the source.

The checkpoints decide from a run's evidence which mistake it looks like; the functions here
say it to the student, at the line of their file where it most likely is (tools.lab.source_scan),
without giving the answer away.
"""
from __future__ import annotations

from tools.lab.evidence import Crash
from tools.lab.result import Hint
from tools.lab.source_scan import Source


def _line(src: Source, *patterns: str) -> int | None:
    for p in patterns:
        n = src.first_line(p)
        if n is not None:
            return n
    return None


def crashed(node: str, crash: Crash) -> Hint:
    if crash.stopped:
        return Hint(crash.file, crash.line, f"{node} stopped with an exception: {crash.error}")
    return Hint(crash.file, crash.line, f"{node} raised {crash.error}: it did nothing else each time")


def syntax(src: Source) -> Hint:
    return Hint(src.name, src.error_line, f"{src.error}: the node cannot start")


def _publishes(src: Source):
    return src.calls("publish")


def never_sent_goal(src: Source) -> Hint:
    send = _publishes(src)
    line = send[0].line if send else _line(src, r"TODO.*[Pp]ublish", r"#.*[Pp]ublish", r"def mainloop")
    return Hint(src.name, line, "tower_to_map never sent the drone a goal: after the tower's goal came, "
                                "nothing reached the publisher (is the goal kept by on_goal, the transform looked "
                                "up, the point published?)")


def not_transformed(src: Source) -> Hint:
    send = _publishes(src)
    return Hint(src.name, send[0].line if send else _line(src, r"def mainloop"),
                "the drone was sent the tower's own coordinates: the goal goes out as it came, in the tower "
                "frame. Transform it into world first (do_transform_point with the world <- tower transform)")


def lookup_direction(src: Source, target: str, source: str, what: str) -> Hint:
    """The lookup's frames the wrong way round: lookup_transform(target_frame, source_frame, time)."""
    calls = [c for c in src.lookups() if len(c.args) >= 2 and c.args[:2] == (source, target)]
    line = calls[0].line if calls else (src.lookups()[0].line if src.lookups() else None)
    return Hint(src.name, line,
                f"{what} went through the inverse transform: lookup_transform({source!r}, {target!r}, ...) "
                f"maps points from {target} into {source}. lookup_transform takes the target frame first, "
                f"then the source: to bring a {source} point into {target}, ask for ({target!r}, {source!r})")


def static_transform_off(launch_file: str, line: int | None, got, want) -> Hint:
    return Hint(launch_file, line,
                f"the drone flew where your static transform puts the tower's goals: the house at "
                f"[{got[0]:.1f}, {got[1]:.1f}], the lab's house is at [{want[0]:.1f}, {want[1]:.1f}] "
                f"(see checkpoint 0)")


def goal_off(src: Source, got, want) -> Hint:
    send = _publishes(src)
    return Hint(src.name, send[0].line if send else None,
                f"the drone's first goal was [{got[0]:.1f}, {got[1]:.1f}] in world; the tower meant the house "
                f"at [{want[0]:.1f}, {want[1]:.1f}]")


def never_broadcast(src: Source, child: str) -> Hint:
    sends = src.calls("sendTransform") + src.calls("send_transform")
    line = sends[0].line if sends else _line(src, r"#.*[Bb]roadcast the", r"def on_position")
    return Hint(src.name, line, f"world_to_drone never broadcast world -> {child}: nothing reached sendTransform "
                                f"with that frame (is the position callback subscribed, the transform built?)")


def wall_clock_stamp(src: Source, offset: float) -> Hint:
    reads = src.wall_clock_reads()
    line = reads[0].line if reads else _line(src, r"stamp\s*=", r"stamp")
    what = f"{reads[0].name}()" if reads else "a clock that is not the drone's"
    return Hint(src.name, line,
                f"the transforms are stamped with {what}, {offset:,.1f} s away from the drone's clock: a "
                f"dynamic transform carries the time of the data it comes from, the drone's time_boot_ms "
                f"(sim seconds), so listeners can look it up at the drone's time")


def frame_not_at_drone(src: Source, child: str, err: float) -> Hint:
    return Hint(src.name, _line(src, rf"[\"']{child}[\"']"),
                f"world -> {child} is {err:.1f} m from where the drone is: its translation is the drone's "
                f"position (LOCAL_POSITION_NED x, y, z), in world")


def roll_pitch_kept(src: Source, tilt_deg: float) -> Hint:
    qfe = [c for c in src.calls("quaternion_from_euler") if c.args[:2] not in ((0, 0), (0.0, 0.0))]
    line = qfe[0].line if qfe else _line(src, r"[\"']drone_yaw[\"']")
    return Hint(src.name, line,
                f"world -> drone_yaw still tilts (up to {tilt_deg:.1f} deg): the level frame keeps only the yaw; "
                f"zero roll and pitch (quaternion_from_euler(0, 0, yaw))")


def never_drove(src: Source) -> Hint:
    send = _publishes(src)
    line = send[0].line if send else _line(src, r"TODO.*[Pp]ublish", r"#.*[Pp]ublish", r"def mainloop")
    return Hint(src.name, line, "ground_robot_controller never sent the rover a goal: nothing reached the "
                                "publisher (is the Buffer made, the transform looked up, the point published?)")


def goal_at_drone_height(src: Source, z: float) -> Hint:
    ps = src.calls("PointStamped")
    return Hint(src.name, ps[0].line if ps else _line(src, r"def mainloop"),
                f"the rover's goal is {-z:.1f} m up, at the drone's height: (0, 0, 0) in the drone frame is the "
                f"drone itself. The ground under the drone is h metres further down its z axis")


def goal_not_through_tilt(src: Source, frame: str) -> Hint:
    return Hint(src.name, _line(src, r"lookup_transform", r"def mainloop"),
                f"the rover's goals stay right under the drone: checkpoint 2's goal is written in the tilting "
                f"frame {frame!r} (self.frame, from --follow-frame), where (0, 0, h) swings with the attitude")


def rover_far(src: Source, rms: float) -> Hint:
    ps = src.calls("PointStamped")
    return Hint(src.name, ps[0].line if ps else _line(src, r"def mainloop"),
                f"the rover stays {rms:.1f} m (RMS) from the ground point under the drone: check the point "
                f"your node publishes (world x, y; z down)")
