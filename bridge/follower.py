"""Rover follow on the bridge: decide what to send; the loop only sends it.

Every drone sample on the one timeline goes to :meth:`Follower.on_drone_sample`; when a
follow tick is due (bridge.follow.FollowSupervisor, --follow-rate sim Hz) it looks up
``world <- drone`` and ``world <- drone_yaw`` at the sample's stamp, computes the ground
points (bridge.follow) and returns the messages to send:

* to the rover: SET_POSITION_TARGET_LOCAL_NED (LOCAL_NED, z 0, the drone's velocity as
  feed-forward unless --no-follow-ff) and, until its HEARTBEAT says so, DO_SET_MODE
  GUIDED (at most every 0.5 s wall) and arming (at most every 1 s wall);
* to the GCS side: TOWERLINK_FOLLOW_STATUS, and STATUSTEXT when following stops or resumes.

:meth:`Follower.check` runs every loop tick: drone telemetry older than --follow-timeout
(sim s) puts the rover in HOLD. Messages are returned as ``(dest, msg)``, dest
``"rover"`` or ``"gcs"``, to be packed as the bridge's own.
"""
from __future__ import annotations

import math

from common.mavlink.dialect import towerlink as tl
from common.frames import TransformException
from common.mavlink.modes import ROVER_GUIDED, ROVER_HOLD
from bridge import translate
from bridge.codec import command_message as _command, statustext_message as _text
from bridge.follow import FollowSupervisor, ground_points
from bridge.origins import origin_frame

MODE_RETRY = 0.5                # s between DO_SET_MODE commands (wall; sim with --lockstep)
ARM_RETRY = 1.0                 # s between arm commands (wall; sim with --lockstep)


class Follower:
    def __init__(self, cfg, buffer, clock, log, warn_once, drone: str = "drone",
                 status: bool = True) -> None:
        self.cfg = cfg
        self.drone = drone                  # the followed drone's frame (and drone + "_yaw")
        self.status = status                # send TOWERLINK_FOLLOW_STATUS (one pair of a family)
        self.buffer = buffer
        self.clock = clock
        self.log = log
        self.warn_once = warn_once
        # with --lockstep `clock` is the world's sim time: the wall fallback needs no speedup
        self.supervisor = FollowSupervisor(cfg.follow_timeout, 1.0 if getattr(cfg, "lockstep", False)
                                           else cfg.speedup, cfg.follow_rate)
        self.state = tl.TOWERLINK_FOLLOW_STATE_WAITING
        self.ticks = 0
        self.last_goal: tuple[float, float] | None = None
        self.mode_wanted: int | None = None
        # with --lockstep the rover's mode and arm commands go out only at the barrier (check):
        # a drone sample is handled mid-frame, when the rover's own packets of that frame may
        # or may not have been read yet (arrival order across links), so the rover's state it
        # sees, and what it would command, would depend on the machine
        self.at_barriers = bool(getattr(cfg, "lockstep", False))
        self._last_mode_cmd = -1e9
        self._last_arm_cmd = -1e9

    def on_drone_sample(self, stamp: float, velocity, reset: bool, rover) -> list[tuple]:
        """A drone sample (stamp s, one timeline; velocity m/s world NED): what to send."""
        if not self.supervisor.on_drone_sample(stamp, self.clock(), reset):
            return []
        return self._tick(stamp, velocity, rover)

    def _tick(self, stamp: float, velocity, rover) -> list[tuple]:
        cfg = self.cfg
        try:
            Tf = self.buffer.lookup_transform(cfg.world_frame, self.drone, stamp)
            Ty = self.buffer.lookup_transform(cfg.world_frame, self.drone + "_yaw", stamp)
        except TransformException as exc:
            self.warn_once(f"follow-lookup-{self.drone}", f"follow: no {self.drone} transform at {stamp:.3f}: {exc}")
            return []
        try:    # the rover's targets are in its own local frame (static: world -> rover_origin)
            To = self.buffer.lookup_transform(origin_frame(rover.name), cfg.world_frame, stamp).transform
        except TransformException as exc:
            self.warn_once("follow-origin", f"follow: rover origin not known yet: {exc}")
            return []
        out: list[tuple] = []
        gp = ground_points(Tf.transform, Ty.transform, cfg.follow_offset, stamp)
        gx, gy = gp.goal(cfg.follow_frame)
        if self.supervisor.holding:
            self.supervisor.holding = False
            self.log("follow: drone telemetry is back; rover resumes following")
            out.append(("gcs", _text("follow: resumed", tl.MAV_SEVERITY_INFO)))
        self.state = tl.TOWERLINK_FOLLOW_STATE_FOLLOWING
        vx, vy = (velocity[0], velocity[1]) if cfg.follow_ff else (0.0, 0.0)
        mask = translate.IGNORE_ACC | translate.IGNORE_YAW | translate.IGNORE_YAW_RATE
        if not cfg.follow_ff:
            mask |= translate.IGNORE_VEL
        lx, ly, _ = To.apply_point((gx, gy, 0.0))
        lvx, lvy, _ = To.apply_vector((vx, vy, 0.0))
        out.append(("rover", tl.MAVLink_set_position_target_local_ned_message(
            int(round(stamp * 1000)) & 0xFFFFFFFF, rover.sysid, 1, tl.MAV_FRAME_LOCAL_NED, mask,
            float(lx), float(ly), 0.0, float(lvx), float(lvy), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
        self.ticks += 1
        self.last_goal = (gx, gy)
        out += self._want_mode(ROVER_GUIDED, rover, send=not self.at_barriers)
        rp = rover.position or (math.nan, math.nan)
        if self.status:
            out.append(("gcs", tl.MAVLink_towerlink_follow_status_message(
                int(round(stamp * 1e6)), gp.ref[0], gp.ref[1], gp.full[0], gp.full[1], gp.yaw[0],
                gp.yaw[1], gx, gy, vx, vy, rp[0], rp[1], gp.height, gp.tilt, gp.err_full, gp.err_yaw,
                0 if cfg.follow_frame == "drone" else 1, self.state)))
        return out

    def check(self, rover, rover_stamp: float | None, rover_wall: float | None) -> list[tuple]:
        """Every tick: HOLD the rover when the drone's telemetry is stale; keep the mode."""
        now = self.clock()
        sup = self.supervisor
        if not sup.holding and sup.stale(now, rover_stamp, rover_wall):
            sup.holding = True
            self.state = tl.TOWERLINK_FOLLOW_STATE_HOLDING
            self.log(f"follow: no {self.drone} telemetry for > {self.cfg.follow_timeout} s (sim); "
                     f"{rover.name} to HOLD")
            return [("gcs", _text(f"follow: {self.drone} lost, {rover.name} HOLD")), *self._want_mode(ROVER_HOLD, rover)]
        if self.mode_wanted is not None:
            return self._ensure_mode(self.mode_wanted, rover)
        return []

    def _want_mode(self, mode: int, rover, send: bool = True) -> list[tuple]:
        if self.mode_wanted != mode:
            self.mode_wanted = mode
            self._last_mode_cmd = -1e9
        return self._ensure_mode(mode, rover) if send else []

    def _ensure_mode(self, mode: int, rover) -> list[tuple]:
        if rover.last_heartbeat_wall is None:
            return []
        out = []
        now = self.clock()
        if rover.custom_mode != mode and now - self._last_mode_cmd > MODE_RETRY:
            self._last_mode_cmd = now
            out.append(("rover", _command(rover.sysid, tl.MAV_CMD_DO_SET_MODE,
                                          tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)))
        if mode == ROVER_GUIDED and not rover.armed and now - self._last_arm_cmd > ARM_RETRY:
            self._last_arm_cmd = now
            out.append(("rover", _command(rover.sysid, tl.MAV_CMD_COMPONENT_ARM_DISARM, 1)))
        return out

