"""Rover follow, pure logic (lab checkpoints 2 and 3): no sockets, no clocks.

The rover's goal is the ground point under the drone written as a point in a drone
frame and transformed to world, z set to 0::

    p_drone = (offset_x, offset_y, +h)      # FRD: "below by the drone's height"
    h       = -z of world -> drone          # NED: height above the ground plane z = 0
    goal    = T_world_frame . p_drone ; goal.z = 0

In the full-attitude frame ``drone`` (checkpoint 2) the point swings by h*sin(tilt)
as the drone pitches and rolls; in the yaw-only frame ``drone_yaw`` (checkpoint 3) it
does not. The offset is meant in the yaw-only frame (negative x = behind); with the
full-attitude frame the same numbers are used in the body frame, as the lab's node would.

:func:`ground_points` computes both candidates and the attitude-free reference
(drone position + yaw-rotated offset) every tick, so the wobble figure is known for
both frames whatever frame drives the rover.

:class:`FollowSupervisor` decides, from clocks given to it, whether the rover should
follow or hold: the drone's telemetry is stale when the rover's clock (same world
clock) is ahead of the drone's newest stamp by more than ``timeout``, or, when no
rover clock is available, when more than ``timeout / speedup`` wall seconds passed
since the last drone sample arrived (a stopped drone clock cannot judge itself).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from common.frames.batch import ground_point

FOLLOW_FRAMES = ("drone", "drone_yaw")


@dataclass(frozen=True)
class GroundPoints:
    """One follow tick's points in world (x, y); z is 0 by construction."""
    stamp: float
    ref: tuple[float, float]        # attitude-free: drone xy + Rz(yaw) offset
    full: tuple[float, float]       # through the full-attitude frame
    yaw: tuple[float, float]        # through the yaw-only frame
    height: float
    tilt: float                     # rad, angle between body z and world z

    @property
    def err_full(self) -> float:
        return math.hypot(self.full[0] - self.ref[0], self.full[1] - self.ref[1])

    @property
    def err_yaw(self) -> float:
        return math.hypot(self.yaw[0] - self.ref[0], self.yaw[1] - self.ref[1])

    def goal(self, frame: str) -> tuple[float, float]:
        if frame == "drone":
            return self.full
        if frame == "drone_yaw":
            return self.yaw
        raise ValueError(f"follow frame must be one of {FOLLOW_FRAMES}, got {frame!r}")


def height_of(T_world_drone) -> float:
    """Height above the ground plane (NED z = 0) from world -> drone."""
    return -float(T_world_drone.translation[2])


def tilt_of(T_world_drone) -> float:
    R = T_world_drone.rotation_matrix()
    return math.acos(max(-1.0, min(1.0, float(R[2, 2]))))


def ground_points(T_world_drone, T_world_drone_yaw=None, offset=(0.0, 0.0),
                  stamp: float = 0.0) -> GroundPoints:
    """Both candidate ground points for one drone pose (see the module docstring)."""
    if T_world_drone_yaw is None:
        T_world_drone_yaw = T_world_drone.yaw_only()
    h = height_of(T_world_drone)
    full = tuple(ground_point(T_world_drone.translation, T_world_drone.rotation, h, offset).tolist())
    yaw = tuple(ground_point(T_world_drone_yaw.translation, T_world_drone_yaw.rotation, h, offset).tolist())
    # reference without any attitude effect: the yaw-only answer computed directly
    t = T_world_drone.translation
    Ry = T_world_drone_yaw.rotation_matrix()
    off = Ry @ np.array((float(offset[0]), float(offset[1]), 0.0))
    ref = (float(t[0] + off[0]), float(t[1] + off[1]))
    return GroundPoints(stamp, ref, full, yaw, h, tilt_of(T_world_drone))


@dataclass
class FollowSupervisor:
    """Follow / hold decisions from the clocks it is given (pure state machine)."""

    timeout: float = 1.0        # sim s without drone telemetry before the rover holds
    speedup: float = 1.0        # for the wall-clock fallback only
    rate_hz: float = 10.0       # follow ticks per sim second
    last_drone_stamp: float | None = None
    last_drone_wall: float | None = None
    last_tick_stamp: float | None = None
    holding: bool = False

    def on_drone_sample(self, stamp: float, wall: float, reset: bool = False) -> bool:
        """Record a drone sample; True when a follow tick is due at this stamp.

        `reset`: the drone's clock went back (the bridge's timeline decides that, not
        this class): its newest stamp and the tick phase start over from `stamp`.
        """
        if reset:
            self.last_drone_stamp = self.last_tick_stamp = None
        if self.last_drone_stamp is None or stamp > self.last_drone_stamp:
            self.last_drone_stamp = stamp
            self.last_drone_wall = wall
        else:
            return False   # old or duplicate sample: never drive the rover backwards in time
        period = 1.0 / self.rate_hz
        if self.last_tick_stamp is None or stamp >= self.last_tick_stamp + period - 1e-6:
            self.last_tick_stamp = stamp
            return True
        return False

    def stale(self, wall: float, rover_stamp: float | None = None,
              rover_wall: float | None = None) -> bool:
        """Is the drone's telemetry older than the timeout?"""
        if self.last_drone_stamp is None:
            return False
        if rover_stamp is not None and rover_wall is not None and \
                wall - rover_wall <= self.timeout / self.speedup:
            # the rover's clock is live: judge in sim time
            return rover_stamp - self.last_drone_stamp > self.timeout
        return wall - self.last_drone_wall > self.timeout / max(self.speedup, 1e-9)
