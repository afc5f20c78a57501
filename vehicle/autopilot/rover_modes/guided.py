"""GUIDED (Rover/mode_guided.cpp ModeGuided): drives to the ground station's targets.

A position target: drive there and stop (a guided WP). A velocity target: that heading and
speed. Yaw only: turn on the spot; yaw rate (+ speed). Velocity and rate targets expire after
GUID_TIMEOUT and the rover stops; acceleration targets are not Rover's and stop it.
Targets are kept and decoded by guided_targets.py; Rover also takes a target with no
position, velocity or acceleration but a yaw or yaw rate (turn in place), as ArduRover.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.guided import ACC_BITS, POS_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE, GuidedTarget
from vehicle.autopilot.guided_targets import GuidedTargets
from vehicle.autopilot.rover_modes.rover_mode import ZERO, RoverMode

NO_MOTION = POS_BITS | VEL_BITS | ACC_BITS
NO_YAW = YAW_IGNORE | YAW_RATE_IGNORE
MAX_YAW_RATE = 10.0          # rad/s
BODY_FRAMES = (mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED)


class ModeGuided(RoverMode):
    number = modes.ROVER_GUIDED
    autopilot_mode = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.targets = GuidedTargets(ap)

    def in_guided_mode(self) -> bool:
        return True

    def enter(self) -> None:
        self.targets.clear()

    def exit(self) -> None:
        self.targets.clear()

    # ----- targets (the link's SET_POSITION_TARGET_*) ----------------------------------
    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        if (type_mask & NO_MOTION) == NO_MOTION and (type_mask & NO_YAW) != NO_YAW:
            return self._turn(frame, type_mask, yaw, yaw_rate)
        return self.targets.position_target_local(frame, type_mask, p, v, a, yaw, yaw_rate)

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        return self.targets.position_target_global(frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate)

    def _turn(self, frame, type_mask, yaw, yaw_rate) -> bool:
        """A yaw-only or yaw-rate-only target: stand and turn."""
        ap = self.ap
        ap.refresh()
        y = yr = None
        if not type_mask & YAW_IGNORE:
            if not math.isfinite(yaw):
                return self.targets.refuse("Guided: yaw not finite")
            rel = frame in BODY_FRAMES
            y = (yaw + (ap.yaw if rel else 0.0) + math.pi) % (2 * math.pi) - math.pi
        if not type_mask & YAW_RATE_IGNORE:
            if not math.isfinite(yaw_rate) or abs(yaw_rate) > MAX_YAW_RATE:
                return self.targets.refuse("Guided: bad yaw rate")
            yr = float(yaw_rate)
        return self.targets.accept(GuidedTarget("vel", None, ZERO.copy(), None, y, yr))

    # ----- the tick -----------------------------------------------------------------------
    def drive(self, dt: float) -> None:
        ap = self.ap
        tgt = self.targets.target
        if tgt is not None and self.targets.timed_out():
            self.targets.clear()
            tgt = None
        # no target, an acceleration target (not Rover's) or nothing to drive to: stop
        if tgt is None or tgt.kind == "acc" or (tgt.pos is None and tgt.vel is None):
            self.stop()
            return
        yaw = tgt.yaw
        if yaw is None and tgt.yaw_rate is not None:
            # RoverFleet steers to headings: lead the heading so the P loop turns at yaw_rate
            yaw = ap.yaw + tgt.yaw_rate / max(0.1, float(ap.params.get("ATC_STR_ANG_P", 2.5)))
        ap.setpoint(pos=tgt.pos, vel=tgt.vel, yaw=yaw, yaw_rate=tgt.yaw_rate)
