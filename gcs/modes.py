"""ArduPilot flight mode numbers (HEARTBEAT custom_mode) and names, for every package.

Copter: ArduCopter/mode.h; Rover: Rover/mode.h. Only the modes towerlink names are listed;
pymavlink's `mode_mapping()` holds ArduPilot's full tables. What each mode does is the
vehicle's business (vehicle/autopilot/modes.py); this module only says the numbers.
"""
from __future__ import annotations

# Copter
STABILIZE, AUTO, GUIDED, LOITER, RTL, LAND = 0, 3, 4, 5, 6, 9
FOLLOW = 23
COPTER_MODES = {STABILIZE: "STABILIZE", AUTO: "AUTO", GUIDED: "GUIDED", LOITER: "LOITER",
                RTL: "RTL", LAND: "LAND", FOLLOW: "FOLLOW"}

# Rover
ROVER_MANUAL, ROVER_HOLD, ROVER_AUTO, ROVER_RTL, ROVER_GUIDED = 0, 4, 10, 11, 15
ROVER_FOLLOW = 6
ROVER_MODES = {ROVER_MANUAL: "MANUAL", ROVER_HOLD: "HOLD", ROVER_AUTO: "AUTO", ROVER_RTL: "RTL",
               ROVER_GUIDED: "GUIDED", ROVER_FOLLOW: "FOLLOW"}


def mode_name(kind: str, number: int) -> str:
    """'GUIDED' for ('copter', 4); 'Mode(N)' for a number not listed. kind: 'copter' | 'rover'."""
    table = COPTER_MODES if kind == "copter" else ROVER_MODES
    return table.get(number, f"Mode({number})")
