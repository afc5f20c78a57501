"""Flight modes: what each mode allows, HEARTBEAT base_mode flags.

The numbers and names are ArduPilot's and live in gcs/modes.py (the bridge and the tools use
them too), so pymavlink's `mode_mapping()` and MAVProxy decode them. Modes we list but do not
implement are refused with "Mode change to X failed: init failed", as ArduPilot says when a
mode's init fails. AUTO (both vehicles) is vehicle/autopilot/auto.py; the copter arms in AUTO
only with AUTO_OPTIONS bit 0 (AllowArming), the rover may.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from gcs.modes import (AUTO, COPTER_MODES, FOLLOW, GUIDED, LAND, LOITER, ROVER_AUTO,  # noqa: F401 (re-exported)
                       ROVER_FOLLOW, ROVER_GUIDED, ROVER_HOLD, ROVER_MANUAL, ROVER_MODES, ROVER_RTL, RTL,
                       STABILIZE, mode_name)

# Copter
COPTER_SUPPORTED = {STABILIZE, AUTO, GUIDED, LOITER, RTL, LAND, FOLLOW}
COPTER_ARMABLE = {STABILIZE, GUIDED, LOITER}
COPTER_NEEDS_POSITION = {AUTO, GUIDED, LOITER, RTL, LAND, FOLLOW}
COPTER_AUTOPILOT_MODES = {AUTO, GUIDED, LOITER, RTL, FOLLOW}      # ArduPilot sets GUIDED_ENABLED

# Rover
ROVER_SUPPORTED = {ROVER_MANUAL, ROVER_HOLD, ROVER_AUTO, ROVER_RTL, ROVER_GUIDED, ROVER_FOLLOW}
ROVER_ARMABLE = {ROVER_MANUAL, ROVER_HOLD, ROVER_AUTO, ROVER_GUIDED, ROVER_FOLLOW}
ROVER_NEEDS_POSITION = {ROVER_AUTO, ROVER_RTL, ROVER_GUIDED, ROVER_FOLLOW}
ROVER_AUTOPILOT_MODES = {ROVER_AUTO, ROVER_RTL, ROVER_GUIDED, ROVER_FOLLOW}
ROVER_MANUAL_INPUT = {ROVER_MANUAL}


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
