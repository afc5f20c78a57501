"""The copter's flight modes, one module each (ArduCopter/mode_*.cpp), and what they share
(copter_mode.py: CopterMode, the user takeoff and the landing descent; stopping.py: the
jerk-limited stop of BRAKE, POSHOLD and GUIDED's pause).

MODES lists the mode classes the copter supports; CopterAutopilot builds one instance of each,
in this order (AUTO flies the RTL object, so RTL comes first). A mode number not here (ACRO,
CIRCLE, DRIFT, SPORT, FLIP, AUTOTUNE, THROW, ...) is answered as an ArduCopter built without
that mode answers it: "No such mode N" and the mode change FAILS. (SITL builds of ArduCopter
include AUTOTUNE, whose init refuses unless flying in STABILIZE, ALT_HOLD, LOITER or POSHOLD:
"Mode change to AUTOTUNE failed: init failed"; towerlink has no tuner to run once it accepts.)
"""
from __future__ import annotations

from vehicle.autopilot.copter_modes.alt_hold import ModeAltHold
from vehicle.autopilot.copter_modes.auto import ModeAuto
from vehicle.autopilot.copter_modes.brake import ModeBrake
from vehicle.autopilot.copter_modes.follow import ModeFollow
from vehicle.autopilot.copter_modes.guided import ModeGuided
from vehicle.autopilot.copter_modes.guided_nogps import ModeGuidedNoGPS
from vehicle.autopilot.copter_modes.land import ModeLand
from vehicle.autopilot.copter_modes.loiter import ModeLoiter
from vehicle.autopilot.copter_modes.poshold import ModePosHold
from vehicle.autopilot.copter_modes.rtl import ModeRTL
from vehicle.autopilot.copter_modes.smart_rtl import ModeSmartRTL
from vehicle.autopilot.copter_modes.stabilize import ModeStabilize

MODES = (ModeStabilize, ModeAltHold, ModeGuided, ModeLoiter, ModeRTL, ModeAuto, ModeLand,
         ModePosHold, ModeBrake, ModeGuidedNoGPS, ModeSmartRTL, ModeFollow)
