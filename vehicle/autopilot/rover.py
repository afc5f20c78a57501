"""ArduRover-like autopilot: its modes (rover_modes/), commands (rover_commands.py) and
failsafe actions (rover_failsafe.py) on the shared Autopilot (base.py).

Setpoints are world NED (z ignored by the RoverFleet), sent every autopilot tick by the
current mode.
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes, rover_modes
from vehicle.autopilot.base import Autopilot
from vehicle.autopilot.ekf_failsafe import RoverEkfCheck
from vehicle.autopilot.rover_commands import RoverCommands
from vehicle.autopilot.radio_failsafe import RoverRadioFailsafe
from vehicle.autopilot.rc_input import ROVER_RECEIVER
from vehicle.autopilot.rover_failsafe import RoverFailsafes

DRIVE_V = 11.1            # V: the drive's nominal voltage
DRIVE_IDLE_A = 1.0        # A standing
DRIVE_A_PER_M_S = 2.0     # A per m/s of speed


class RoverAutopilot(Autopilot):
    kind = "rover"
    mav_type = mav.MAV_TYPE_GROUND_ROVER
    mode_classes = rover_modes.MODES
    initial_mode = modes.ROVER_HOLD
    receiver = ROVER_RECEIVER           # its throttle centred (reverse)
    GUIDED, AUTO, RTL, SMART_RTL = modes.ROVER_GUIDED, modes.ROVER_AUTO, modes.ROVER_RTL, modes.ROVER_SMART_RTL
    commands_class = RoverCommands
    failsafe_class = RoverFailsafes
    radio_failsafe_class = RoverRadioFailsafe
    ekf_check_class = RoverEkfCheck
    speed_param = ("WP_SPEED", 1.0, 0.0, 100.0)     # m/s; WP_SPEED 0 means CRUISE_SPEED to the rover core

    def electrical_load(self) -> float:
        """The drive's electrical power (W): about 1 A standing plus 2 A per m/s at 11.1 V."""
        return DRIVE_V * (DRIVE_IDLE_A + DRIVE_A_PER_M_S * float(np.linalg.norm(self.vel[:2])))

    def landed_state(self) -> int:
        return mav.MAV_LANDED_STATE_ON_GROUND

    def home_from_fix(self) -> np.ndarray:
        """Home at the first good estimate: here."""
        return self.pos.copy()

    def mode_change_failed(self, mode, reason: str) -> None:
        """Rover::set_mode says the same whatever Mode::enter refused for (no reason)."""
        self.text(mav.MAV_SEVERITY_WARNING, "Flight mode change failed")
