"""GUIDED (ArduCopter/mode_guided.cpp ModeGuided): flies the ground station's targets.

On the ground: motors idle until MAV_CMD_NAV_TAKEOFF (the user takeoff, straight up to the
altitude asked). In the air: the last target (position / position+velocity / velocity /
acceleration, with yaw or yaw rate; guided_targets.py), holding position when there is none;
velocity and acceleration targets expire after GUID_TIMEOUT (3 s) and the copter stops and
holds. A destination outside an enabled fence is ignored (ArduPilot logs DEST_OUTSIDE_FENCE
and keeps its previous target). MAV_CMD_DO_PAUSE_CONTINUE pauses (decelerates at WPNAV_ACCEL
to a stop and holds, stopping.py) and continues the target, as ModeGuided::pause()/resume().

SET_ATTITUDE_TARGET (attitude_target.py) switches to attitude control (guided_angle.py:
attitude or body rates, climb rate or thrust; it takes off from the ground on a positive
climb rate); a position target or a takeoff switches back. A target ArduCopter cannot fly
(THROTTLE_IGNORE, a quaternion not of unit length, some body rates ignored and others not)
stops the copter as ModeGuided::init(true) does: a zero velocity target (brake, then hold).
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.attitude_target import AttitudeStop, AttitudeTarget, decode_copter
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.copter_modes.guided_angle import GuidedAngle
from vehicle.autopilot.copter_modes.stopping import StopThenHold
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.guided_targets import GuidedTargets
from vehicle.autopilot.mode import ArmingMethod

TAKEOFF_DONE_M = 0.3     # m below the takeoff altitude counts as there


class ModeGuided(CopterMode):
    number = modes.GUIDED
    position_required, autopilot_mode, user_takeoff = True, True, True
    reports_guided_enabled = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.angle = GuidedAngle(ap)
        self.targets = GuidedTargets(ap, lambda ned: ap.fence.destination_ok(ned), accepted=self.angle.stop)
        self.paused = False
        self.stop = StopThenHold(ap)

    def allows_arming(self, method: ArmingMethod) -> bool:
        """Always from the ground station; from the transmitter only with GUID_OPTIONS bit 0
        (AllowArmingFromTX), which towerlink does not model: never."""
        return method is ArmingMethod.MAVLINK

    def allows_arming_with_throttle_high(self) -> bool:
        return True

    def in_guided_mode(self) -> bool:
        return True

    def enter(self) -> None:
        self.targets.clear()
        self.angle.stop()

    def exit(self) -> None:
        super().exit()
        self.stop.release()
        self.paused = False
        self.targets.clear()
        self.angle.stop()

    def leaves_ground(self) -> bool:
        return super().leaves_ground() or (self.angle.active and self.angle.takes_off())

    # ----- targets (the link's SET_POSITION_TARGET_*) ----------------------------------
    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        return self.targets.position_target_local(frame, type_mask, p, v, a, yaw, yaw_rate)

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        return self.targets.position_target_global(frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate)

    def attitude_target(self, type_mask: int, q, body_rates, thrust: float) -> bool:
        """SET_ATTITUDE_TARGET: attitude control from now, or ArduCopter's stop."""
        try:
            tgt = self.decode_attitude(type_mask, q, body_rates, thrust)
        except AttitudeStop as e:
            self.stop_moving(str(e))
            return False
        self.targets.clear()
        self.ap.takeoff.stop()
        self.angle.set(tgt)
        return True

    def decode_attitude(self, type_mask: int, q, body_rates, thrust: float) -> AttitudeTarget:
        """The target as ArduCopter reads it with this copter's parameters (AttitudeStop)."""
        ap = self.ap
        ap.refresh()
        p = ap.params
        return decode_copter(type_mask, q, body_rates, thrust, int(p.get("GUID_OPTIONS", 0)),
                             float(p.get("WPNAV_SPEED_UP", 250)) / 100.0, float(p.get("WPNAV_SPEED_DN", 150)) / 100.0)

    def stop_moving(self, why: str) -> None:
        """ModeGuided::init(true): a zero velocity target at the current heading (brake, then
        hold); towerlink says `why` when there is a reason."""
        ap = self.ap
        if why:
            ap.text(mav.MAV_SEVERITY_WARNING, why)
        self.targets.accept(GuidedTarget("vel", None, np.zeros(3), None, ap.yaw, None))

    def set_yaw(self, yaw: float) -> None:
        """MAV_CMD_CONDITION_YAW: face `yaw` (rad, wrapped), the target's yaw too."""
        self.ap.hold_yaw = yaw
        if self.targets.target is not None:
            self.targets.target.yaw = yaw

    # ----- takeoff ------------------------------------------------------------------------
    def do_user_takeoff_start(self, alt_m: float) -> bool:
        ap = self.ap
        z = ap.pos[2] - alt_m
        ap.takeoff.start(z)
        self.targets.clear()
        self.angle.stop()
        ap.hold_pos = np.array([ap.pos[0], ap.pos[1], z])
        ap.hold_yaw = ap.yaw
        ap.echo = GuidedTarget("pos", ap.hold_pos.copy(), None, None, ap.hold_yaw, None)
        ap.text(mav.MAV_SEVERITY_INFO, f"Takeoff to {alt_m:.1f} m")
        return True

    # ----- pause / resume -----------------------------------------------------------------
    def pause(self) -> bool:
        ap = self.ap
        if not self.paused:
            self.paused = True
            ap.hold_here()
            if ap.armed and not ap.on_ground:     # decelerate to a stop, then hold there
                self.stop.start(float(ap.params.get("WPNAV_ACCEL", 250)) / 100.0,
                                float(ap.params.get("PSC_JERK_XY", 5.0)))
        return True

    def resume(self) -> bool:
        self.stop.release()
        self.paused = False
        self.targets.time = self.ap.t                # the target's timeout restarts
        return True

    # ----- the tick -----------------------------------------------------------------------
    def run(self, dt: float) -> None:
        if self.angle.active:
            self.angle.update(dt)
        super().run(dt)

    def fly(self, dt: float) -> None:
        if self.paused:
            self.stop.run(dt)
            return
        if self.angle.active:
            self.angle.fly()
            return
        ap = self.ap
        takeoff = ap.takeoff
        if takeoff.running and (ap.pos[2] <= takeoff.alt_z + TAKEOFF_DONE_M or self.targets.target is not None):
            takeoff.stop()
        tgt = self.targets.target
        if tgt is not None and self.targets.timed_out():
            self.targets.clear()
            ap.hold_here()
            tgt = None
        if tgt is None:
            ap.setpoint(pos=ap.hold_pos, yaw=ap.hold_yaw)
            return
        yaw = tgt.yaw if tgt.yaw is not None else (None if tgt.yaw_rate is not None else ap.hold_yaw)
        if tgt.yaw is not None:
            ap.hold_yaw = tgt.yaw
        elif tgt.yaw_rate is not None:
            ap.hold_yaw = ap.yaw
        ap.setpoint(pos=tgt.pos, vel=tgt.vel, acc=tgt.acc, yaw=yaw, yaw_rate=tgt.yaw_rate)
