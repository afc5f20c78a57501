"""Flight mode numbers and names, for the autopilot's own use.

The numbers and names are ArduPilot's and live in common/mavlink/modes.py (the bridge and the
tools use them too), so pymavlink's `mode_mapping()` and MAVProxy decode them. What each mode
does, allows and reports is its mode object's (copter_modes/, rover_modes/; mode.py).
"""
from __future__ import annotations

from common.mavlink.modes import (ALT_HOLD, AUTO, BRAKE, COPTER_MODES, FOLLOW, GUIDED,  # noqa: F401 (re-exported)
                                  GUIDED_NOGPS, LAND, LOITER, POSHOLD, ROVER_ACRO, ROVER_AUTO, ROVER_FOLLOW, ROVER_GUIDED,
                                  ROVER_HOLD, ROVER_LOITER, ROVER_MANUAL, ROVER_MODES, ROVER_RTL,
                                  ROVER_SMART_RTL, ROVER_STEERING, RTL, SMART_RTL, STABILIZE, mode_name)
