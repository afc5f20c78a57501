"""ArduCopter-like autopilot: its modes (copter_modes/), arming (copter_arming.py), commands
(copter_commands.py), failsafe actions (copter_failsafe.py) and crash check (crash_check.py) on
the shared Autopilot (base.py).

Setpoints are world NED, sent to the CopterFleet every autopilot tick by the current mode.
DISARM_DELAY: disarms after that long landed without a takeoff in progress, as ArduPilot's
auto-disarm does with throttle at zero (copter_modes/copter_mode.py).
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import copter_modes, modes
from vehicle.autopilot.base import Autopilot
from vehicle.autopilot.battery import MOTOR_EFFICIENCY
from vehicle.autopilot.copter_arming import CopterArming
from vehicle.autopilot.copter_commands import CopterCommands
from vehicle.autopilot.copter_failsafe import CopterFailsafes
from vehicle.autopilot.copter_modes.copter_mode import UserTakeoff
from vehicle.autopilot.crash_check import CopterCrashCheck
from vehicle.autopilot.ekf_failsafe import CopterEkfCheck
from vehicle.autopilot.radio_failsafe import CopterRadioFailsafe


class CopterAutopilot(Autopilot):
    kind = "copter"
    mav_type = mav.MAV_TYPE_QUADROTOR
    mode_classes = copter_modes.MODES
    initial_mode = modes.STABILIZE
    GUIDED, AUTO, RTL, SMART_RTL = modes.GUIDED, modes.AUTO, modes.RTL, modes.SMART_RTL
    arming_class = CopterArming
    commands_class = CopterCommands
    failsafe_class = CopterFailsafes
    radio_failsafe_class = CopterRadioFailsafe
    ekf_check_class = CopterEkfCheck
    crash_check_class = CopterCrashCheck
    speed_param = ("WPNAV_SPEED", 100.0, 500.0, 20.0)      # cm/s; 20 m/s is WPNAV_SPEED's maximum

    def __init__(self, *a, **kw) -> None:
        self.takeoff = UserTakeoff()              # ArduCopter's Mode::takeoff, shared by the modes
        self.landed_since: float | None = None    # sim s since landed (DISARM_DELAY)
        super().__init__(*a, **kw)

    def home_from_fix(self) -> np.ndarray:
        """Home at the first good estimate: here, never below the ground (z <= 0)."""
        home = self.pos.copy()
        home[2] = max(home[2], 0.0)
        return home

    def electrical_load(self) -> float:
        """The rotors' shaft power over the motor and ESC efficiency (W): drains with thrust."""
        return self.fleet.rotor_power(self.i) / MOTOR_EFFICIENCY

    def landed_state(self) -> int:
        """EXTENDED_SYS_STATE's MAV_LANDED_STATE, from the mode's is_taking_off / is_landing."""
        if not self.armed:
            return mav.MAV_LANDED_STATE_ON_GROUND
        mode = self.flightmode
        if mode.is_taking_off():
            return mav.MAV_LANDED_STATE_TAKEOFF
        if self.on_ground:
            return mav.MAV_LANDED_STATE_ON_GROUND
        if mode.is_landing():
            return mav.MAV_LANDED_STATE_LANDING
        return mav.MAV_LANDED_STATE_IN_AIR
