"""GUIDED (Rover/mode_guided.cpp ModeGuided): drives to the ground station's targets.

A position target: drive there and stop (a guided WP). A velocity target: that heading and
speed. Yaw only: turn on the spot; yaw rate (+ speed). Velocity and rate targets expire after
GUID_TIMEOUT and the rover stops; acceleration targets are not Rover's and stop it.
Targets are kept and decoded by guided_targets.py; Rover also takes a target with no
position, velocity or acceleration but a yaw or yaw rate (turn in place), as ArduRover.

SET_ATTITUDE_TARGET (attitude_target.py, as ArduRover's handle_set_attitude_target): thrust
times the default speed (WP_SPEED, or CRUISE_SPEED when it is 0) on the quaternion's heading,
or turning at the body yaw rate; THROTTLE_IGNORE is ignored. No new one for 3 s: "target not
received last 3secs, stopping" and the rover stops (ArduRover's fixed 3 s). towerlink's
skid-steer rover does not reverse: a negative thrust stops it on the heading instead of
backing up.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.attitude_target import RoverAttitudeTarget, decode_rover
from vehicle.autopilot.guided import ACC_BITS, POS_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE, GuidedTarget
from vehicle.autopilot.guided_targets import GuidedTargets
from vehicle.autopilot.rover_modes.rover_mode import ZERO, RoverMode

NO_MOTION = POS_BITS | VEL_BITS | ACC_BITS
NO_YAW = YAW_IGNORE | YAW_RATE_IGNORE
MAX_YAW_RATE = 10.0          # rad/s
BODY_FRAMES = (mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED)
ATTITUDE_TIMEOUT_S = 3.0     # ArduRover's heading-and-speed / turn-rate-and-speed timeout


class ModeGuided(RoverMode):
    number = modes.ROVER_GUIDED
    autopilot_mode = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.attitude: RoverAttitudeTarget | None = None     # the last SET_ATTITUDE_TARGET
        self.attitude_time = 0.0
        self.targets = GuidedTargets(ap, accepted=self._drop_attitude)

    def in_guided_mode(self) -> bool:
        return True

    def enter(self) -> None:
        self.targets.clear()
        self.attitude = None

    def exit(self) -> None:
        self.targets.clear()
        self.attitude = None

    def _drop_attitude(self) -> None:
        self.attitude = None

    def attitude_target(self, type_mask: int, q, body_rates, thrust: float) -> bool:
        p = self.ap.params
        speed = float(p.get("WP_SPEED", 0)) or float(p.get("CRUISE_SPEED", 8))
        tgt = decode_rover(type_mask, q, body_rates[2], thrust, speed)
        if tgt is None:
            return False
        self.targets.clear()
        self.attitude, self.attitude_time = tgt, self.ap.t
        return True

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
        if self.attitude is not None:
            if ap.t - self.attitude_time <= ATTITUDE_TIMEOUT_S:
                self._drive_attitude(self.attitude)
                return
            ap.text(mav.MAV_SEVERITY_WARNING, "target not received last 3secs, stopping")
            self.attitude = None
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

    def _drive_attitude(self, tgt: RoverAttitudeTarget) -> None:
        """Speed on a heading, or speed while turning at a rate (the heading led by the
        steering gain, as drive() does for a yaw rate)."""
        ap = self.ap
        speed = max(0.0, tgt.speed)
        if tgt.heading is None and speed == 0.0:
            ap.setpoint(vel=ZERO.copy(), yaw_rate=tgt.yaw_rate)          # turn in place
            ap.echo = GuidedTarget("vel", None, ZERO.copy(), None, None, tgt.yaw_rate)
            return
        heading = tgt.heading
        if heading is None:
            heading = ap.yaw + tgt.yaw_rate / max(0.1, float(ap.params.get("ATC_STR_ANG_P", 2.5)))
        vel = np.array([speed * math.cos(heading), speed * math.sin(heading), 0.0])
        ap.setpoint(vel=vel, yaw=heading)
        ap.echo = GuidedTarget("vel", None, vel, None, heading, tgt.yaw_rate)
