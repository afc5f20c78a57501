"""AUTO's mission commands: how each one starts and when it is done (a mixin of AutoMission).

What each command does, as ArduCopter's / ArduRover's ModeAuto do it (learned from their
source, re-expressed here):

- NAV_WAYPOINT / NAV_SPLINE_WAYPOINT (spline flown as a straight waypoint: towerlink has
  no spline shaper): fly to the point (0,0 = here, alt 0 = current altitude). Reached
  when within WPNAV_RADIUS (copter, cm) / WP_RADIUS (rover, m); then it waits param1
  seconds. Copter says "Reached command #N", Rover "Reached waypoint #N" (with
  ". Loiter for S seconds" when it waits). ArduCopter and ArduRover store neither the
  acceptance radius (param2) nor the yaw (param4) of a NAV_WAYPOINT (only Plane keeps
  param2), so both are ignored here too; the copter faces the next waypoint
  (WP_YAW_BEHAVIOR 2, the default) unless an ROI or CONDITION_YAW says otherwise.
- NAV_TAKEOFF (copter): climb straight up to the item's altitude (at least 1 m up);
  done at that altitude. On the ground it waits for "auto armed": MISSION_START, a
  GUIDED takeoff, AUTO_OPTIONS bit 1 (AllowTakeOffWithoutRaisingThrottle), or the pilot's
  throttle raised above zero (an RC override: vehicle/autopilot/rc_input.py).
- NAV_LAND (copter): at a position -> fly there at the current altitude, then descend;
  else descend here. Landed -> disarm (the land item is not reported reached, as
  ArduCopter). NAV_RETURN_TO_LAUNCH: the vehicle's RTL mode object flies it (rally points
  included); done once landed (copter) / arrived (rover).
- NAV_LOITER_UNLIM: go there and stay (never done). NAV_LOITER_TIME: go there, stay
  param1 s. NAV_LOITER_TURNS (copter): circle param1 turns of radius |param3| m
  (negative = counter-clockwise) around the point, "Mission: starting circle k/n".
  NAV_DELAY: hold param1 s, "Delaying N sec".
- DO_CHANGE_SPEED (param1 0/1 horizontal, 2 climb, 3 descent; param2 m/s > 0), DO_SET_HOME
  (param1 1 = here), DO_SET_ROI / DO_SET_ROI_LOCATION (copter yaws at it; position 0,0
  = ROI off), CONDITION_DELAY (param1 s), CONDITION_DISTANCE (param1 m to the current
  destination), CONDITION_YAW (copter: param1 deg, param2 deg/s, param3 -1 ccw / 1 cw,
  param4 1 relative). Anything else: "Skipping invalid cmd #<command id>" (this includes
  DO_PAUSE_CONTINUE as a mission item; as a COMMAND it pauses and continues the flight).
- Every completed command sends MISSION_ITEM_REACHED (ap.item_reached(seq)).
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common.frames.batch import wrap_pi
from vehicle.autopilot.mission_geo import ItemFrameError, has_position, item_alt_z, item_ned
from vehicle.autopilot.mission_store import MissionItem

SEV_INFO, SEV_WARNING = mav.MAV_SEVERITY_INFO, mav.MAV_SEVERITY_WARNING
C = mav
TAKEOFF_DONE_M = 0.3          # m from the takeoff altitude counts as reached
YAW_DONE_RAD = math.radians(2.0)
DO_DONE = {C.MAV_CMD_DO_CHANGE_SPEED, C.MAV_CMD_DO_SET_HOME, C.MAV_CMD_DO_SET_ROI,
           C.MAV_CMD_DO_SET_ROI_LOCATION, C.MAV_CMD_DO_SET_ROI_NONE, C.MAV_CMD_DO_LAND_START}


class AutoCommands:
    """start_command / verify_command for the MissionRunner; state lives on AutoMission."""

    # ----- command start ----------------------------------------------------------------
    def _home_z(self) -> float:
        ap = self.ap
        return float(ap.home[2]) if ap.home is not None else float(ap.start_ned[2])

    def _ned(self, item: MissionItem, default: np.ndarray | None = None) -> np.ndarray:
        d = np.array(self.ap.pos if default is None else default, float)
        return item_ned(item, self.ap.origin, self._home_z(), d)

    def _default_dest(self) -> np.ndarray:
        """Where "here" is for a new waypoint: the last destination once reached (ArduPilot)."""
        if self.dest is not None and self.reached_at is not None:
            return self.dest.copy()
        return self.ap.pos.copy()

    def start_command(self, item: MissionItem) -> bool:
        try:
            return self._start(item)
        except ItemFrameError as e:
            self.ap.text(SEV_WARNING, str(e)[:50])
            return False

    def _start(self, item: MissionItem) -> bool:
        ap, c = self.ap, item.command
        if c in (C.MAV_CMD_NAV_WAYPOINT, C.MAV_CMD_NAV_SPLINE_WAYPOINT):
            self._goto(self._ned(item, self._default_dest()), max(0.0, _num(item.param1)))
            return True
        if c == C.MAV_CMD_NAV_TAKEOFF and self.copter:
            z = item_alt_z(item, ap.origin, self._home_z())
            self.takeoff_z = min(z, ap.pos[2] - (1.0 if ap.on_ground else 0.0))
            self.dest = np.array([ap.pos[0], ap.pos[1], self.takeoff_z])
            self.reached_at = None
            self.sub = "takeoff"
            return True
        if c == C.MAV_CMD_NAV_LAND and self.copter:
            if has_position(item):
                dest = self._ned(item)
                dest[2] = ap.pos[2]
                self._goto(dest, 0.0)
                self.land_stage = "fly"
            else:
                self.land_stage = "descend"
                self.sub = "land"
                ap.hold_here()
            return True
        if c == C.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            self.rtl.start()
            self.sub = "rtl"
            return True
        if c in (C.MAV_CMD_NAV_LOITER_UNLIM, C.MAV_CMD_NAV_LOITER_TIME):
            hold = max(0.0, _num(item.param1)) if c == C.MAV_CMD_NAV_LOITER_TIME else math.inf
            self._goto(self._ned(item, self._default_dest()), hold)
            return True
        if c == C.MAV_CMD_NAV_LOITER_TURNS and self.copter:
            center = self._ned(item)
            self.circle = dict(center=center, radius=abs(_num(item.param3)), turns=max(0.0, _num(item.param1)),
                               ccw=_num(item.param3) < 0, angle=None, total=0.0, last=-1)
            self.sub = "circle"
            self.dest = center
            return True
        if c == C.MAV_CMD_NAV_DELAY:
            secs = max(0.0, _num(item.param1))
            self.delay_until = ap.t + secs
            ap.text(SEV_INFO, f"Delaying {int(secs)} sec")
            self.sub = "loiter" if self.copter else "stop"
            ap.hold_here()
            return True
        # do / condition commands
        if c == C.MAV_CMD_CONDITION_DELAY:
            self.cond_until = ap.t + max(0.0, _num(item.param1))
        elif c == C.MAV_CMD_CONDITION_DISTANCE:
            self.cond_dist = max(0.0, _num(item.param1))
        elif c == C.MAV_CMD_CONDITION_YAW and self.copter:
            self._condition_yaw(item)
        elif c == C.MAV_CMD_DO_CHANGE_SPEED:
            self._change_speed(item)
        elif c == C.MAV_CMD_DO_SET_HOME:
            if _num(item.param1) == 1 or not has_position(item):
                ap.commands.set_home([1, 0, 0, 0, 0, 0, 0], None, None, None)
            else:
                ap.commands.set_home([0, 0, 0, 0, 0, 0, float(item.z)], item.frame, item.x, item.y)
        elif c in (C.MAV_CMD_DO_SET_ROI, C.MAV_CMD_DO_SET_ROI_LOCATION, C.MAV_CMD_DO_SET_ROI_NONE):
            self.roi = self._ned(item) if has_position(item) and c != C.MAV_CMD_DO_SET_ROI_NONE else None
        else:
            return False
        return True

    def _goto(self, dest: np.ndarray, hold_s: float) -> None:
        self.dest = np.asarray(dest, float)
        self.hold_s = hold_s
        self.reached_at = None
        self.sub = "wp"
        self.paused = False
        if self.fixed_yaw is not None and self.roi is None:
            self.fixed_yaw = None          # a new waypoint takes yaw back (WP_YAW_BEHAVIOR)

    def _condition_yaw(self, item: MissionItem) -> None:
        ang = math.radians(_num(item.param1))
        if _num(item.param4) == 1:
            ang = self.ap.yaw + (-ang if _num(item.param3) < 0 else ang)
        self.fixed_yaw = wrap_pi(ang)
        rate = _num(item.param2)
        self.yaw_rate_max = math.radians(rate) if rate > 0 else math.radians(90.0)

    def _change_speed(self, item: MissionItem) -> None:
        kind, speed = int(_num(item.param1)), _num(item.param2)
        if speed <= 0:
            return
        ap = self.ap
        if not self.copter:
            ap.speed.change(speed)
            ap.text(SEV_INFO, f"speed: {speed:.1f} m/s")
        elif kind in (0, 1):
            ap.speed.change(speed)
        elif kind == 2:
            ap.push_params({"WPNAV_SPEED_UP": speed * 100.0})
        elif kind == 3:
            ap.push_params({"WPNAV_SPEED_DN": speed * 100.0})

    # ----- command verify ---------------------------------------------------------------
    def verify_command(self, item: MissionItem) -> bool:
        done = self._verify(item)
        if done:
            self.ap.item_reached(item.seq)
        return done

    def _verify(self, item: MissionItem) -> bool:
        ap, c = self.ap, item.command
        if c in (C.MAV_CMD_NAV_WAYPOINT, C.MAV_CMD_NAV_SPLINE_WAYPOINT):
            return self._verify_wp(item)
        if c == C.MAV_CMD_NAV_TAKEOFF:
            return self.sub == "takeoff" and not ap.on_ground and abs(ap.pos[2] - self.takeoff_z) < TAKEOFF_DONE_M
        if c == C.MAV_CMD_NAV_LAND:
            if self.land_stage == "fly":
                if self._arrived():
                    self.land_stage, self.sub = "descend", "land"
                    ap.hold_pos = np.array([self.dest[0], self.dest[1], ap.pos[2]])
                return False
            if ap.armed and ap.on_ground and self.sub == "land" and ap.t - ap.arm_time > 1.0:
                ap.disarm(force=True, reason="landed")
            return False
        if c == C.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self.rtl.complete()
        if c == C.MAV_CMD_NAV_LOITER_UNLIM:
            if not self.copter:
                self._verify_wp(item)            # ArduRover still says "Reached waypoint #N"
            return False
        if c == C.MAV_CMD_NAV_LOITER_TIME:
            return self._verify_wp(item, say=self.copter)
        if c == C.MAV_CMD_NAV_LOITER_TURNS:
            return self._verify_circle()
        if c == C.MAV_CMD_NAV_DELAY:
            return ap.t >= self.delay_until
        if c == C.MAV_CMD_CONDITION_DELAY:
            return ap.t >= self.cond_until
        if c == C.MAV_CMD_CONDITION_DISTANCE:
            return self.dest is not None and self.distance_to_dest() < self.cond_dist
        if c == C.MAV_CMD_CONDITION_YAW and self.copter:
            return self.fixed_yaw is not None and abs(wrap_pi(ap.yaw - self.fixed_yaw)) < YAW_DONE_RAD
        if c in DO_DONE:
            return True
        ap.text(SEV_WARNING, f"Skipping invalid cmd #{c}")
        return True

    def _verify_circle(self) -> bool:
        c = self.circle
        if c is None:
            return True
        if c["angle"] is None:               # still flying to the edge
            return False
        done = c["total"] / (2 * math.pi)
        if int(done) != c["last"]:
            # ArduCopter says this on every new turn, the one that ends the command included
            c["last"] = int(done)
            self.ap.text(SEV_INFO, f"Mission: starting circle {int(done) + 1}/{int(c['turns'])}")
        return done >= c["turns"]

    def wp_radius(self) -> float:
        p = self.ap.params
        return float(p.get("WPNAV_RADIUS", 200)) / 100.0 if self.copter else float(p.get("WP_RADIUS", 2.0))

    def distance_to_dest(self) -> float:
        d = self.ap.pos - self.dest
        return float(np.linalg.norm(d if self.copter else d[:2]))

    def _verify_wp(self, item: MissionItem, say: bool = True) -> bool:
        ap = self.ap
        if self.reached_at is None:
            if self.dest is None or not self._arrived():
                return False
            self.reached_at = ap.t
            if not self.copter:
                msg = f"Reached waypoint #{item.seq}"
                if 0 < self.hold_s < math.inf:
                    msg += f". Loiter for {int(self.hold_s)} seconds"
                ap.text(SEV_INFO, msg)
        if ap.t - self.reached_at < self.hold_s:
            return False
        if self.copter and say:
            ap.text(SEV_INFO, f"Reached command #{item.seq}")
        elif item.command == C.MAV_CMD_NAV_LOITER_TIME:
            ap.text(SEV_WARNING, "Finished active loiter")
        return True

    def _arrived(self) -> bool:
        if self.distance_to_dest() <= self.wp_radius():
            return True
        if self.copter:
            return False
        # rover: passed the destination (beyond the line through it, square to the leg)
        v = self.ap.vel[:2]
        to = self.dest[:2] - self.ap.pos[:2]
        return float(np.linalg.norm(v)) > 0.2 and float(np.dot(v, to)) < 0 and float(np.linalg.norm(to)) < 2 * self.wp_radius() + 1


def _num(v: float) -> float:
    """A stored param as a finite float (NaN/inf -> 0: bad uploads never crash the flight)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return 0.0
    return f if math.isfinite(f) else 0.0
