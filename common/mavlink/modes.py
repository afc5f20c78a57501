"""ArduPilot flight mode numbers (HEARTBEAT custom_mode) and names, for every package.

Copter: ArduCopter/mode.h; Rover: Rover/mode.h. Only the modes towerlink names are listed;
pymavlink's `mode_mapping()` holds ArduPilot's full tables. What each mode does is the
vehicle's business (vehicle/autopilot/modes.py); this module only says the numbers.
"""
from __future__ import annotations

# Copter (names as ArduCopter's Mode::name() and pymavlink's mode_mapping())
STABILIZE, ALT_HOLD, AUTO, GUIDED, LOITER, RTL, LAND = 0, 2, 3, 4, 5, 6, 9
POSHOLD, BRAKE, GUIDED_NOGPS, SMART_RTL, FOLLOW = 16, 17, 20, 21, 23
COPTER_MODES = {STABILIZE: "STABILIZE", ALT_HOLD: "ALT_HOLD", AUTO: "AUTO", GUIDED: "GUIDED",
                LOITER: "LOITER", RTL: "RTL", LAND: "LAND", POSHOLD: "POSHOLD", BRAKE: "BRAKE",
                GUIDED_NOGPS: "GUIDED_NOGPS", SMART_RTL: "SMART_RTL", FOLLOW: "FOLLOW"}

# Rover
ROVER_MANUAL, ROVER_ACRO, ROVER_STEERING, ROVER_HOLD, ROVER_LOITER = 0, 1, 3, 4, 5
ROVER_FOLLOW, ROVER_AUTO, ROVER_RTL, ROVER_SMART_RTL, ROVER_GUIDED = 6, 10, 11, 12, 15
ROVER_MODES = {ROVER_MANUAL: "MANUAL", ROVER_ACRO: "ACRO", ROVER_STEERING: "STEERING",
               ROVER_HOLD: "HOLD", ROVER_LOITER: "LOITER", ROVER_FOLLOW: "FOLLOW", ROVER_AUTO: "AUTO",
               ROVER_RTL: "RTL", ROVER_SMART_RTL: "SMART_RTL", ROVER_GUIDED: "GUIDED"}


def mode_name(kind: str, number: int) -> str:
    """'GUIDED' for ('copter', 4); 'Mode(N)' for a number not listed. kind: 'copter' | 'rover'."""
    table = COPTER_MODES if kind == "copter" else ROVER_MODES
    return table.get(number, f"Mode({number})")
