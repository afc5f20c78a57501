"""Flight modes: ArduPilot numbers and names, what each mode allows, HEARTBEAT base_mode flags.

Numbers are ArduPilot's (Copter: ArduCopter/mode.h, Rover: Rover/mode.h) so pymavlink's
`mode_mapping()` and MAVProxy decode them. Modes we list but do not implement are
refused with "Mode change to X failed: init failed", as ArduPilot says when a mode's
init fails. AUTO (both vehicles) is vehicle/autopilot/auto.py; the copter arms in AUTO
only with AUTO_OPTIONS bit 0, the rover may.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

# Copter
STABILIZE, AUTO, GUIDED, LOITER, RTL, LAND = 0, 3, 4, 5, 6, 9
COPTER_MODES = {STABILIZE: "STABILIZE", AUTO: "AUTO", GUIDED: "GUIDED", LOITER: "LOITER",
                RTL: "RTL", LAND: "LAND"}
COPTER_SUPPORTED = {STABILIZE, AUTO, GUIDED, LOITER, RTL, LAND}
COPTER_ARMABLE = {STABILIZE, GUIDED, LOITER}
COPTER_NEEDS_POSITION = {AUTO, GUIDED, LOITER, RTL, LAND}
COPTER_AUTOPILOT_MODES = {AUTO, GUIDED, LOITER, RTL}      # ArduPilot sets GUIDED_ENABLED

# Rover
R_MANUAL, R_HOLD, R_AUTO, R_RTL, R_GUIDED = 0, 4, 10, 11, 15
ROVER_MODES = {R_MANUAL: "MANUAL", R_HOLD: "HOLD", R_AUTO: "AUTO", R_RTL: "RTL", R_GUIDED: "GUIDED"}
ROVER_SUPPORTED = {R_MANUAL, R_HOLD, R_AUTO, R_RTL, R_GUIDED}
ROVER_ARMABLE = {R_MANUAL, R_HOLD, R_AUTO, R_GUIDED}
ROVER_NEEDS_POSITION = {R_AUTO, R_RTL, R_GUIDED}
ROVER_AUTOPILOT_MODES = {R_AUTO, R_RTL, R_GUIDED}
ROVER_MANUAL_INPUT = {R_MANUAL}


def mode_name(kind: str, number: int) -> str:
    table = COPTER_MODES if kind == "copter" else ROVER_MODES
    return table.get(number, f"Mode({number})")


def base_mode(kind: str, number: int, armed: bool) -> int:
    """HEARTBEAT base_mode as ArduPilot's GCS_MAVLINK::base_mode() builds it."""
    if kind == "copter":
        flags = mav.MAV_MODE_FLAG_STABILIZE_ENABLED | mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if number in COPTER_AUTOPILOT_MODES:
            flags |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
    else:
        flags = 0
        if number in ROVER_MANUAL_INPUT:
            flags |= mav.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if number in ROVER_AUTOPILOT_MODES:
            flags |= mav.MAV_MODE_FLAG_GUIDED_ENABLED
    if armed:
        flags |= mav.MAV_MODE_FLAG_SAFETY_ARMED
    return flags | mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
