"""ArduRover-like autopilot: MANUAL, HOLD, AUTO, GUIDED, RTL.

Setpoints (world NED; z ignored by the RoverFleet):
  MANUAL   no RC input, so throttle and steering are neutral: stopped.
  HOLD     stopped.
  GUIDED   position target (drive there and stop, as a Rover guided WP), velocity target
           (heading and speed), yaw only (turn on the spot), yaw rate (+ speed); velocity
           and rate targets expire after GUID_TIMEOUT and the rover stops.
  RTL      drives home (or to the nearest rally point, rally.py), says "Reached destination"
           inside WP_RADIUS and holds there.
  AUTO     the mission (auto.py): drives to each waypoint at WP_SPEED / CRUISE_SPEED, stops
           for NAV_DELAY / hold times, holds at the end ("Mission Complete").
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.base import SEV_INFO, SEV_WARNING, Autopilot, UNSUPPORTED
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mission_store import RALLY
from vehicle.autopilot.rally import best_return, rally_points
from vehicle.autopilot.rover_modes import RoverModes

ZERO = np.zeros(3)


class RoverAutopilot(RoverModes, Autopilot):
    kind = "rover"
    mav_type = mav.MAV_TYPE_GROUND_ROVER
    mode_names = modes.ROVER_MODES
    supported = modes.ROVER_SUPPORTED
    armable = modes.ROVER_ARMABLE
    needs_position = modes.ROVER_NEEDS_POSITION
    guided_mode = modes.ROVER_GUIDED
    auto_mode = modes.ROVER_AUTO
    rtl_mode = modes.ROVER_RTL
    initial_mode = modes.ROVER_HOLD

    def __init__(self, *a, **kw) -> None:
        self.rtl_done = False
        self.rtl_dest = np.zeros(3)
        super().__init__(*a, **kw)

    # ArduRover's FailsafeAction priorities, highest first: Terminate, Hold, RTL,
    # SmartRTL_Hold, SmartRTL, None
    failsafe_priorities = (5, 2, 1, 4, 3, 0)

    def electrical_load(self) -> float:
        """The drive's electrical power (W): about 1 A standing plus 2 A per m/s at 11.1 V."""
        return 11.1 * (1.0 + 2.0 * float(np.linalg.norm(self.vel[:2])))

    def battery_failsafe_action(self, action: int) -> None:
        """Rover::handle_battery_failsafe: 1 RTL or Hold, 2 Hold, 3 SmartRTL or RTL or Hold,
        4 SmartRTL or Hold, 5 Terminate (disarm)."""
        if action == 5:
            self.disarm(force=True)
            return
        chain = {1: (modes.ROVER_RTL, modes.ROVER_HOLD), 2: (modes.ROVER_HOLD,),
                 3: (mav.ROVER_MODE_SMART_RTL, modes.ROVER_RTL, modes.ROVER_HOLD),
                 4: (mav.ROVER_MODE_SMART_RTL, modes.ROVER_HOLD)}.get(action, ())
        for m in chain:
            if self.mode == m or self.set_mode(m, "battery failsafe"):
                return

    def enter_mode(self, number: int) -> None:
        super().enter_mode(number)
        if number == modes.ROVER_RTL:
            self.rtl_start()
        self.enter_extra_mode(number)

    follow_mode = modes.ROVER_FOLLOW

    def follow_refused(self, number: int) -> None:
        self.mode_init_failed(number)          # Rover's ModeFollow::_enter fails without a word

    def mode_init_failed(self, number: int) -> None:
        self.text(SEV_WARNING, "Flight mode change failed")     # Rover::set_mode's words

    # ----- RTL (home or rally point) ----------------------------------------------------
    def rtl_start(self) -> None:
        self.refresh()
        self.rtl_done = False
        home = self.home if self.home is not None else self.start_ned
        pts = rally_points(self.missions.items(RALLY), self.origin, float(home[2]))
        self.rtl_dest, _ = best_return(self.pos, home, pts, float(self.params.get("RALLY_LIMIT_KM", 0.5)),
                                       int(self.params.get("RALLY_INCL_HOME", 1)) == 1)

    def rtl_complete(self) -> bool:
        return self.rtl_done

    def _rtl_drive(self) -> None:
        dest = self.rtl_dest
        if not self.rtl_done and np.linalg.norm(self.pos[:2] - dest[:2]) < float(self.params.get("WP_RADIUS", 2)) + 0.5:
            self.rtl_done = True
            self.text(SEV_INFO, "Reached destination")
            self.hold_here()
        if self.rtl_done:
            self._stop()
        else:
            tgt = np.array([dest[0], dest[1], self.pos[2]])
            self.echo = GuidedTarget("pos", tgt, None, None, None, None)
            self.setpoint(pos=tgt)

    # ----- AUTO -----------------------------------------------------------------------
    def auto_fly(self, a, dt: float) -> None:
        if not self.armed or a.sub == "stop" or a.paused or a.dest is None and a.sub != "rtl":
            self._stop()
            return
        if a.sub == "rtl":
            self._rtl_drive()
            return
        tgt = np.array([a.dest[0], a.dest[1], self.pos[2]])
        self.echo = GuidedTarget("pos", tgt, None, None, None, None)
        self.setpoint(pos=tgt)

    def fence_action_rover(self, action: int) -> None:
        """FENCE_ACTION 1: RTL (HOLD if RTL cannot start); 2: HOLD; 3: SmartRTL, else RTL, else
        HOLD; 4: SmartRTL, else HOLD (ArduRover's fence actions)."""
        self._failsafe_mode(action, "fence breach")

    def _failsafe_mode(self, action: int, reason: str) -> int:
        """FS_ACTION / FENCE_ACTION 1 RTL, 2 Hold, 3 SmartRTL->RTL->Hold, 4 SmartRTL->Hold:
        the mode it got into."""
        tries = {1: [modes.ROVER_RTL], 3: [modes.ROVER_SMART_RTL, modes.ROVER_RTL],
                 4: [modes.ROVER_SMART_RTL]}.get(action, [])
        for m in tries + [modes.ROVER_HOLD]:
            if self.set_mode(m, reason):
                return m
        return self.mode

    def landed_state(self) -> int:
        return mav.MAV_LANDED_STATE_ON_GROUND

    def vehicle_command(self, cmd, p, frame, x, y) -> int:
        return UNSUPPORTED

    def reposition_speed(self, speed: float | None) -> None:
        """ArduRover: a positive DO_REPOSITION param1 is the GUIDED speed (m/s)."""
        if speed is not None:
            self.speed_override = min(float(speed), 100.0)
            self.apply_speed()

    def apply_speed(self) -> None:
        # WP_SPEED 0 means CRUISE_SPEED to the rover core, so the parameter itself is the default
        speed = self.speed_override if self.speed_override is not None else float(self.params.get("WP_SPEED", 0))
        self.push_params({"WP_SPEED": speed})

    def gcs_failsafe_action(self, enable: int) -> None:
        action = int(self.params.get("FS_ACTION", 2))
        if action == 0:
            self.text(SEV_WARNING, "GCS Failsafe")
            return
        got = self._failsafe_mode(action, "GCS failsafe")
        name = {modes.ROVER_RTL: "RTL", modes.ROVER_SMART_RTL: "SmartRTL"}.get(got, "Hold")
        self.text(SEV_WARNING, f"GCS Failsafe On: {name}")

    def _stop(self) -> None:
        self.setpoint(vel=ZERO.copy(), yaw_rate=0.0)
        self.echo = GuidedTarget("vel", None, ZERO.copy(), None, None, 0.0)

    def run_mode(self, dt: float) -> None:
        if self.mode == modes.ROVER_AUTO:
            self.auto.run(dt)
            return
        if not self.armed or self.mode in (modes.ROVER_MANUAL, modes.ROVER_HOLD):
            self._stop()
            return
        if self.mode == modes.ROVER_RTL:
            self._rtl_drive()
            return
        if self.mode == modes.ROVER_FOLLOW:
            self._follow()
            return
        if self.run_extra_mode(self.mode):      # ACRO, STEERING, LOITER, SMART_RTL (rover_modes.py)
            return
        # GUIDED
        tgt = self.target
        if tgt is not None and self.guided_timed_out():
            self.target = None
            tgt = None
        if tgt is None:
            self._stop()
            return
        if tgt.kind == "acc":        # Rover has no acceleration targets: treat as a stop
            self._stop()
            return
        if tgt.pos is None and tgt.vel is None:
            self._stop()
            return
        yaw = tgt.yaw
        if yaw is None and tgt.yaw_rate is not None:
            # RoverFleet steers to headings: lead the heading so the P loop turns at yaw_rate
            yaw = self.yaw + tgt.yaw_rate / max(0.1, float(self.params.get("ATC_STR_ANG_P", 2.5)))
        self.setpoint(pos=tgt.pos, vel=tgt.vel, yaw=yaw, yaw_rate=tgt.yaw_rate)

    def _follow(self) -> None:
        """FOLLOW (Rover/mode_follow.cpp): drive at the lead's velocity plus FOLL_POS_P times
        the offset error, within WP_SPEED (else CRUISE_SPEED); no valid lead: stop."""
        p = self.params
        speed = float(p.get("WP_SPEED", 0)) or float(p.get("CRUISE_SPEED", 8))
        if self.speed_override:
            speed = self.speed_override
        cmd = self.follow.command(self.t, self.pos, speed, float(p.get("ATC_ACCEL_MAX", 2.0)) or 2.0, None)
        if cmd is None or np.hypot(cmd.vel[0], cmd.vel[1]) < 0.05:
            self._stop()
            return
        self.setpoint(vel=cmd.vel)
        self.echo = GuidedTarget("vel", None, cmd.vel, None, None, None)

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        """Rover also takes yaw-only and yaw-rate-only targets (turn in place), as ArduRover."""
        import math as _m
        from vehicle.autopilot.guided import ACC_BITS, POS_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE
        if (self.in_guided() and (type_mask & (POS_BITS | VEL_BITS | ACC_BITS)) == (POS_BITS | VEL_BITS | ACC_BITS)
                and (type_mask & (YAW_IGNORE | YAW_RATE_IGNORE)) != (YAW_IGNORE | YAW_RATE_IGNORE)):
            self.refresh()
            y = yr = None
            if not type_mask & YAW_IGNORE:
                if not _m.isfinite(yaw):
                    return self._refuse("Guided: yaw not finite")
                rel = frame in (mav.MAV_FRAME_BODY_NED, mav.MAV_FRAME_BODY_OFFSET_NED)
                y = (yaw + (self.yaw if rel else 0.0) + _m.pi) % (2 * _m.pi) - _m.pi
            if not type_mask & YAW_RATE_IGNORE:
                if not _m.isfinite(yaw_rate) or abs(yaw_rate) > 10:
                    return self._refuse("Guided: bad yaw rate")
                yr = float(yaw_rate)
            return self.accept_target(GuidedTarget("vel", None, ZERO.copy(), None, y, yr))
        return super().position_target_local(frame, type_mask, p, v, a, yaw, yaw_rate)
