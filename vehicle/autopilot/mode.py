"""A flight mode as ArduPilot models one (ArduCopter/mode.h `Mode`, Rover/mode.h `Mode`): an
object per mode that says what it allows and flies the vehicle while it is current.

The autopilot (base.py) holds one instance of each mode it supports (number -> Mode) and
calls the current one's hooks; it has no chain of mode numbers. Every mode change goes
through Autopilot.set_mode, in this order:

  new.init(ignore_checks)   may refuse (False); ArduPilot passes ignore_checks = not armed
  old.exit()                the old mode's clean-up
  new.enter()               the new mode starts (the hold point is taken just before)

ArduCopter's init() both checks and starts the mode, before the old mode's exit(). Here most
modes start in enter(), after exit(), so that one mode's clean-up (BRAKE giving back its
WPNAV_ACCEL) cannot undo the next one's start; AUTO still starts in init(), as ArduPilot's.
Every autopilot tick the autopilot then calls read_pilot_input() and run(dt).

Setpoints, positions and targets are the SITL world's NED (m, z down) throughout.
"""
from __future__ import annotations

import enum
from typing import ClassVar


class ArmingMethod(enum.Enum):
    """AP_Arming::Method: who asks to arm. Every request towerlink gets comes over MAVLink;
    the RC ones (the rudder stick, an auxiliary switch) are not modelled."""
    MAVLINK = "mavlink"
    RUDDER = "rudder"
    AUXSWITCH = "auxswitch"


class Mode:
    """One flight mode of one autopilot. Subclasses name their ArduPilot counterpart."""

    number: ClassVar[int] = -1                   # HEARTBEAT custom_mode
    names: ClassVar[dict[int, str]] = {}         # the vehicle's mode names (common/mavlink/modes.py)

    def __init__(self, ap) -> None:
        self.ap = ap          # the Autopilot (base.py) this mode flies

    @property
    def name(self) -> str:
        """The mode's name as STATUSTEXT and ground stations spell it."""
        return self.names.get(self.number, str(self.number))

    # ----- life cycle ----------------------------------------------------------------
    def init(self, ignore_checks: bool) -> bool:
        """May this mode start now? False refuses the change (the autopilot then says
        "... failed"). `ignore_checks` is ArduPilot's: True when disarmed, when a mode skips
        the checks the arming checks make again (ArduCopter's AUTO without a mission); the
        checks a mode makes either way (FOLLOW's FOLL_ENABLE, SMART_RTL's path) ignore it."""
        return True

    def enter(self) -> None:
        """The mode has become current (after the old one's exit and the new hold point)."""

    def exit(self) -> None:
        """The mode stops being current: undo what it changed (limits, borrowed state)."""

    def run(self, dt: float) -> None:
        """One autopilot tick (dt s) in this mode: setpoints for the fleet."""
        raise NotImplementedError

    def read_pilot_input(self) -> None:
        """Each tick before run(): what the mode keeps from the pilot's sticks
        (ap.rc.sticks, vehicle/autopilot/rc_input.py; the copter's auto_armed). The modes
        flown by the sticks read them in run() (ArduPilot's get_pilot_desired_*)."""

    # ----- what the mode is ------------------------------------------------------------
    # Each mode declares ArduPilot's answers here; the hooks below return them, and a mode
    # whose answer depends on its state or a parameter overrides the hook instead.
    position_required: ClassVar[bool] = True     # requires_position()
    arming_allowed: ClassVar[bool] = True        # allows_arming()
    autopilot_mode: ClassVar[bool] = False       # is_autopilot()
    mission_required: ClassVar[bool] = False     # the vehicle's current_mode_requires_mission()

    def requires_position(self) -> bool:
        """ArduCopter requires_GPS() / Rover requires_position(): refused without a
        position estimate while armed ("Mode change to X failed: requires position")."""
        return self.position_required

    def requires_mission(self) -> bool:
        """Copter/Rover current_mode_requires_mission() (AUTO): no arming without a mission
        ("PreArm: Mode requires mission", AP_Arming::mission_checks)."""
        return self.mission_required

    def allows_arming(self, method: ArmingMethod) -> bool:
        """May the vehicle arm in this mode (pre-arm "Mode not armable" otherwise)?"""
        return self.arming_allowed

    def is_autopilot(self) -> bool:
        """ArduCopter is_autopilot() / Rover is_autopilot_mode(): the vehicle flies itself."""
        return self.autopilot_mode

    def in_guided_mode(self) -> bool:
        """External targets (SET_POSITION_TARGET_*, SET_ATTITUDE_TARGET, DO_REPOSITION) are
        taken; the mode's own hooks below say what it does with each."""
        return False

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_LOCAL_NED in this mode; False: ignored."""
        return False

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_GLOBAL_INT in this mode; False: ignored."""
        return False

    def attitude_target(self, type_mask: int, q, body_rates, thrust: float) -> bool:
        """SET_ATTITUDE_TARGET in this mode (vehicle/autopilot/attitude_target.py); False:
        ignored or refused."""
        return False

    def is_taking_off(self) -> bool:
        """A takeoff is under way (MAV_LANDED_STATE_TAKEOFF; not idle on the ground)."""
        return False

    def is_landing(self) -> bool:
        """The mode is descending to land (MAV_LANDED_STATE_LANDING; the Min Alt fence is
        off). ArduPilot's failsafes also consult it (a landing may be left to finish); the
        failsafe actions towerlink models do not yet."""
        return False

    # ----- MAV_CMD_DO_PAUSE_CONTINUE -----------------------------------------------------
    def pause(self) -> bool:
        """Stop and hold where the mode allows it; False where it cannot pause."""
        return False

    def resume(self) -> bool:
        """Continue after pause(); False where the mode cannot."""
        return False

    def base_mode_flags(self) -> int:
        """HEARTBEAT base_mode flags this mode sets (ARMED and CUSTOM_MODE are the autopilot's)."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name} ({self.number})>"
