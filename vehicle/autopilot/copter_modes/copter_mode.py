"""What every copter mode shares (ArduCopter/mode.h `Mode`, mode.cpp, takeoff.cpp, land
helpers): the hooks ArduCopter adds for a multicopter, the ground handling every mode runs
first, the user takeoff and the landing descent.

No RC is simulated, so each mode runs as ArduCopter does with the sticks centred.
Setpoints are world NED (m, z down) for the CopterFleet.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mode import Mode

LAND_ALT_LOW = 10.0     # m: below it LAND descends at LAND_SPEED (LAND_ALT_LOW's default, cm / 100)
MAX_TAKEOFF_M = 1000.0  # m: a NAV_TAKEOFF higher than this is refused
LANDED_DISARM_S = 1.0   # s armed before a landing mode may disarm on the ground


class UserTakeoff:
    """ArduCopter's Mode::_TakeOff: the user takeoff (MAV_CMD_NAV_TAKEOFF), one per copter and
    shared by its modes; any mode change stops it (Copter::exit_mode's takeoff_stop())."""

    def __init__(self) -> None:
        self.alt_z: float | None = None    # world z (m, down) the takeoff climbs to
        self.running = False

    def start(self, alt_z: float) -> None:
        self.alt_z, self.running = alt_z, True

    def stop(self) -> None:
        self.alt_z, self.running = None, False


class CopterMode(Mode):
    """A copter mode. Subclasses fly in `fly(dt)`; run() first handles disarmed and landed."""

    names = modes.COPTER_MODES

    disarm_on_land = False      # LAND, RTL, SMART_RTL: disarm once landed (after LANDED_DISARM_S armed)
    reports_guided_enabled = False
    """HEARTBEAT base_mode's GUIDED_ENABLED in this mode. ArduCopter sets it while its
    horizontal position controller runs (AC_PosControl::is_active_NE(), so also in LAND,
    BRAKE and POSHOLD); towerlink reports it, as it always has, for AUTO, GUIDED, LOITER,
    RTL, SMART_RTL and FOLLOW."""

    # ----- ArduCopter's Mode hooks (values declared as in Mode) --------------------------
    manual_throttle: ClassVar[bool] = False      # has_manual_throttle()
    user_takeoff: ClassVar[bool] = False         # has_user_takeoff()

    def has_manual_throttle(self) -> bool:
        """The pilot's throttle stick drives the motors (STABILIZE, ACRO)."""
        return self.manual_throttle

    def has_user_takeoff(self, must_navigate: bool) -> bool:
        """MAV_CMD_NAV_TAKEOFF may start a takeoff in this mode (must_navigate: param3 == 0,
        the mode must hold position while it climbs)."""
        return self.user_takeoff

    def is_taking_off(self) -> bool:
        return self.ap.takeoff.running

    def base_mode_flags(self) -> int:
        flags = mav.MAV_MODE_FLAG_STABILIZE_ENABLED | mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        return flags | (mav.MAV_MODE_FLAG_GUIDED_ENABLED if self.reports_guided_enabled else 0)

    def exit(self) -> None:
        self.ap.takeoff.stop()          # Copter::exit_mode cancels any takeoff in progress

    # ----- the tick ---------------------------------------------------------------------
    def run(self, dt: float) -> None:
        """Disarmed: no setpoint (motors off). Landed and not taking off: a landing mode
        disarms, the others idle (make_safe_ground_handling). Else the mode flies."""
        ap = self.ap
        if not ap.armed:
            ap.setpoint()
            return
        if ap.on_ground and not self.leaves_ground():
            if self.disarm_on_land and ap.t - ap.arm_time > LANDED_DISARM_S:
                ap.disarm(force=True, reason="landed")
                return
            self.ground_idle()
            return
        ap.landed_since = None
        self.fly(dt)

    def leaves_ground(self) -> bool:
        """Armed on the ground: does the mode fly now rather than idle? (a takeoff under way,
        or GUIDED's attitude control asking to climb)"""
        return self.is_taking_off()

    def fly(self, dt: float) -> None:
        """Setpoints in the air (armed, or taking off)."""
        raise NotImplementedError

    def ground_idle(self) -> None:
        """On the ground without a takeoff: idle; DISARM_DELAY s later disarm (ArduCopter's
        auto-disarm with the throttle at zero)."""
        ap = self.ap
        if ap.landed_since is None:
            ap.landed_since = ap.t
        delay = float(ap.params.get("DISARM_DELAY", 10))
        if delay > 0 and ap.t - ap.landed_since >= delay:
            ap.disarm(force=True, reason="auto-disarm")
            return
        ap.setpoint()
        ap.hold_here()

    # ----- user takeoff (takeoff.cpp) -----------------------------------------------------
    def do_user_takeoff(self, alt_m: float, must_navigate: bool) -> bool:
        """MAV_CMD_NAV_TAKEOFF to alt_m (0 < alt_m <= 1000) above here: armed, landed, a mode
        with a user takeoff that starts one; then the copter is auto-armed (AUTO's takeoff may
        start)."""
        ap = self.ap
        if not ap.armed or not ap.on_ground or not self.has_user_takeoff(must_navigate):
            return False
        if not math.isfinite(alt_m) or alt_m <= 0 or alt_m > MAX_TAKEOFF_M:
            return False
        if not self.do_user_takeoff_start(alt_m):
            return False
        ap.auto_armed = True
        return True

    def do_user_takeoff_start(self, alt_m: float) -> bool:
        """Start the takeoff. ArduCopter's ALT_HOLD, LOITER and POSHOLD climb on the pilot's
        throttle (_TakeOff::do_pilot_takeoff), which needs RC: towerlink flies only GUIDED's
        takeoff, so the others refuse here."""
        return False

    # ----- landing (land_run_horiz_and_vert_control) ---------------------------------------
    def descent_speed(self) -> float:
        """m/s down: WPNAV_SPEED_DN (or LAND_SPEED_HIGH) above LAND_ALT_LOW, LAND_SPEED below."""
        ap = self.ap
        p = ap.params
        home_z = ap.home[2] if ap.home is not None else 0.0
        if home_z - ap.pos[2] > float(p.get("LAND_ALT_LOW", 100 * LAND_ALT_LOW)) / 100.0:
            hi = float(p.get("LAND_SPEED_HIGH", 0)) or float(p.get("WPNAV_SPEED_DN", 150))
            return hi / 100.0
        return float(p.get("LAND_SPEED", 50)) / 100.0

    def land_run(self) -> None:
        """Descend at descent_speed() over ap.hold_pos's x, y (altitude free); without a
        position estimate level, drifting (ArduCopter's ModeLand::nogps_run)."""
        ap = self.ap
        speed = self.descent_speed()
        if not ap.est_ok:
            ap.setpoint(vel=np.array([0.0, 0.0, speed]), yaw=ap.hold_yaw, level=True)
            return
        x, y = ap.hold_pos[0], ap.hold_pos[1]
        ap.echo = GuidedTarget("posvel", np.array([x, y, ap.pos[2]]), np.array([0.0, 0.0, speed]),
                               None, ap.hold_yaw, None)
        ap.setpoint(pos=np.array([x, y, np.nan]), vel=np.array([0.0, 0.0, speed]), yaw=ap.hold_yaw)
