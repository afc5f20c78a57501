"""What every copter mode shares (ArduCopter/mode.h `Mode`, mode.cpp, takeoff.cpp, land
helpers): the hooks ArduCopter adds for a multicopter, the ground handling every mode runs
first, the user takeoff and the landing descent.

The pilot's sticks come from the RC input (vehicle/autopilot/rc_input.py: the simulated
receiver, a GCS's RC_CHANNELS_OVERRIDE or MANUAL_CONTROL); each mode reads them through its
PilotControl (pilot_control.py). Before any RC frame every stick reads centred and each mode
runs as ArduCopter does with the sticks centred. With it, read_pilot_input() keeps ArduCopter's
auto_armed (update_auto_armed): set once armed with the throttle above zero, cleared in a
manual-throttle mode when the throttle is back at zero (not in the radio failsafe).
LAND_REPOSITION lets the sticks move a landing (LAND, RTL's and AUTO's final descent) and
the yaw stick turns it. Setpoints are world NED (m, z down) for the CopterFleet.
"""
from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.pilot_control import PilotControl
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

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.pilot = PilotControl(ap)

    disarm_on_land = False      # LAND, RTL, SMART_RTL: disarm once landed (after LANDED_DISARM_S armed)
    reports_guided_enabled = False
    """HEARTBEAT base_mode's GUIDED_ENABLED in this mode. ArduCopter sets it while its
    horizontal position controller runs (AC_PosControl::is_active_NE(), so also in LAND,
    BRAKE and POSHOLD); towerlink reports it, as it always has, for AUTO, GUIDED, LOITER,
    RTL, SMART_RTL and FOLLOW."""

    # ----- ArduCopter's Mode hooks (values declared as in Mode) --------------------------
    manual_throttle: ClassVar[bool] = False      # has_manual_throttle()
    pilot_takeoff: ClassVar[bool] = False        # a climb asked on the ground takes off (_TakeOff)
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

    def crash_check_enabled(self) -> bool:
        """The crash check runs in this mode (crash_check.py; ArduCopter's ACRO and FLIP say
        no, and towerlink has neither)."""
        return True

    def allows_arming_with_throttle_high(self) -> bool:
        """allows_GCS_or_SCR_arming_with_throttle_high: a GCS may arm with the throttle up
        (the "Throttle too high" arm check is skipped)."""
        return False

    def disarms_on_failsafe(self, throttle_zero: bool) -> bool:
        """Copter::should_disarm_on_failsafe in this mode: landed (no takeoff under way),
        or in a manual-throttle mode with the throttle at zero."""
        landed = self.ap.on_ground and not self.ap.takeoff.running
        return landed or (self.has_manual_throttle() and throttle_zero)

    def base_mode_flags(self) -> int:
        flags = mav.MAV_MODE_FLAG_STABILIZE_ENABLED | mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        return flags | (mav.MAV_MODE_FLAG_GUIDED_ENABLED if self.reports_guided_enabled else 0)

    def exit(self) -> None:
        self.ap.takeoff.stop()          # Copter::exit_mode cancels any takeoff in progress
        self.pilot.release()

    def enter(self) -> None:
        self.pilot.reset()

    def read_pilot_input(self) -> None:
        """update_auto_armed from the throttle (only once there is RC input)."""
        ap = self.ap
        if ap.rc.sticks is None or not ap.armed:
            return
        zero = ap.radio.throttle_zero
        if ap.auto_armed:
            if self.has_manual_throttle() and zero and not ap.radio.active:
                ap.auto_armed = False
        elif not zero:
            ap.auto_armed = True

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
        the pilot's climb in a mode with a pilot takeoff, or GUIDED's attitude control asking
        to climb)"""
        return self.is_taking_off() or (self.pilot_takeoff and self.pilot.wanted_climb() > 0.0)

    def fly_pilot_angles(self, z: float, vz: float, roll: float, pitch: float, yaw_rate: float) -> None:
        """The pilot's lean angles (rad) at the held heading turning at yaw_rate (rad/s), the
        altitude z held (NaN: climbing at -vz m/s)."""
        ap = self.ap
        ap.echo = None
        ap.setpoint(pos=np.array([np.nan, np.nan, z]), vel=np.array([0.0, 0.0, vz]), roll=roll, pitch=pitch,
                    yaw=ap.hold_yaw, yaw_rate=yaw_rate)

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

    def land_run(self, dt: float = 0.0, pause: bool = False) -> None:
        """Descend at descent_speed() over ap.hold_pos's x, y (altitude free); without a
        position estimate level, drifting (ArduCopter's ModeLand::nogps_run). With
        LAND_REPOSITION the roll and pitch sticks move that point at LOITER's pilot velocity
        (the copter flies it as feed-forward); the yaw stick turns the heading. pause: a climb
        rate of 0 instead (land_run_vertical_control's pause_descent): the copter stops where
        its braking takes it and holds that altitude."""
        ap = self.ap
        speed = 0.0 if pause else self.descent_speed()
        if not ap.est_ok:
            ap.setpoint(vel=np.array([0.0, 0.0, speed]), yaw=ap.hold_yaw, level=True)
            return
        vn = ve = 0.0
        rate = None
        if ap.rc.sticks is not None and not ap.radio.active:
            if int(ap.params.get("LAND_REPOSITION", 1)):
                vn, ve = self.pilot.velocity(dt)
                ap.hold_pos[0] += vn * dt
                ap.hold_pos[1] += ve * dt
            rate = self.pilot.yaw(dt) or None
        x, y = ap.hold_pos[0], ap.hold_pos[1]
        ap.echo = GuidedTarget("posvel", np.array([x, y, ap.pos[2]]), np.array([vn, ve, speed]),
                               None, ap.hold_yaw, None)
        ap.setpoint(pos=np.array([x, y, np.nan]), vel=np.array([vn, ve, speed]), yaw=ap.hold_yaw,
                    yaw_rate=rate)
