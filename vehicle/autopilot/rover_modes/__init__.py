"""The rover's modes, one module each (Rover/mode_*.cpp), and what they share
(rover_mode.py: RoverMode).

MODES lists the mode classes the rover supports; RoverAutopilot builds one instance of each,
in this order (AUTO drives the RTL object, so RTL comes first).
"""
from __future__ import annotations

from vehicle.autopilot.rover_modes.acro import ModeAcro
from vehicle.autopilot.rover_modes.auto import ModeAuto
from vehicle.autopilot.rover_modes.follow import ModeFollow
from vehicle.autopilot.rover_modes.guided import ModeGuided
from vehicle.autopilot.rover_modes.hold import ModeHold
from vehicle.autopilot.rover_modes.loiter import ModeLoiter
from vehicle.autopilot.rover_modes.manual import ModeManual
from vehicle.autopilot.rover_modes.rtl import ModeRTL
from vehicle.autopilot.rover_modes.smart_rtl import ModeSmartRTL
from vehicle.autopilot.rover_modes.steering import ModeSteering

MODES = (ModeManual, ModeAcro, ModeSteering, ModeHold, ModeLoiter, ModeFollow, ModeRTL, ModeAuto,
         ModeSmartRTL, ModeGuided)
