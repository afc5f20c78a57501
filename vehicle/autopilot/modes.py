"""Flight modes: what each mode allows, HEARTBEAT base_mode flags.

The numbers and names are ArduPilot's and live in common/mavlink/modes.py (the bridge and the tools use
them too), so pymavlink's `mode_mapping()` and MAVProxy decode them. Modes we list but do not
implement are refused with "Mode change to X failed: init failed", as ArduPilot says when a
mode's init fails. AUTO (both vehicles) is vehicle/autopilot/auto.py; the copter arms in AUTO
only with AUTO_OPTIONS bit 0 (AllowArming), the rover may.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.modes import (ALT_HOLD, AUTO, BRAKE, COPTER_MODES, FOLLOW, GUIDED, LAND,  # noqa: F401 (re-exported)
                       LOITER, POSHOLD, ROVER_ACRO, ROVER_AUTO, ROVER_FOLLOW, ROVER_GUIDED, ROVER_HOLD,
                       ROVER_LOITER, ROVER_MANUAL, ROVER_MODES, ROVER_RTL, ROVER_SMART_RTL,
                       ROVER_STEERING, RTL, SMART_RTL, STABILIZE, mode_name)

# Copter (FOLLOW: vehicle/autopilot/follow_mode.py)
COPTER_SUPPORTED = {STABILIZE, ALT_HOLD, AUTO, GUIDED, LOITER, RTL, LAND, POSHOLD, BRAKE, SMART_RTL, FOLLOW}
# ArduCopter's allows_arming(): not AUTO (unless AUTO_OPTIONS), RTL, LAND, BRAKE, SMART_RTL
COPTER_ARMABLE = {STABILIZE, ALT_HOLD, GUIDED, LOITER, POSHOLD}
# requires_GPS(): every mode that holds or flies to a position
COPTER_NEEDS_POSITION = {AUTO, GUIDED, LOITER, RTL, LAND, POSHOLD, BRAKE, SMART_RTL, FOLLOW}
COPTER_AUTOPILOT_MODES = {AUTO, GUIDED, LOITER, RTL, SMART_RTL, FOLLOW}      # ArduPilot sets GUIDED_ENABLED

# Rover (FOLLOW: vehicle/autopilot/follow_mode.py)
ROVER_SUPPORTED = {ROVER_MANUAL, ROVER_ACRO, ROVER_STEERING, ROVER_HOLD, ROVER_LOITER, ROVER_AUTO,
                   ROVER_RTL, ROVER_SMART_RTL, ROVER_GUIDED, ROVER_FOLLOW}
ROVER_ARMABLE = {ROVER_MANUAL, ROVER_ACRO, ROVER_STEERING, ROVER_HOLD, ROVER_LOITER, ROVER_AUTO,
                 ROVER_GUIDED, ROVER_FOLLOW}
ROVER_NEEDS_POSITION = {ROVER_AUTO, ROVER_RTL, ROVER_GUIDED, ROVER_LOITER, ROVER_SMART_RTL, ROVER_FOLLOW}
ROVER_AUTOPILOT_MODES = {ROVER_AUTO, ROVER_RTL, ROVER_GUIDED, ROVER_LOITER, ROVER_SMART_RTL, ROVER_FOLLOW}
ROVER_MANUAL_INPUT = {ROVER_MANUAL, ROVER_ACRO, ROVER_STEERING}


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
