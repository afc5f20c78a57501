"""BRAKE (ArduCopter/mode_brake.cpp ModeBrake): stops as fast as it may, then holds.

Horizontal deceleration BRAKE_MODE_DECEL_RATE (750 cm/s/s, ArduCopter's config.h) reached at
PSC_JERK_XY, altitude held (stopping.py); once stopped it holds that point. Entered disarmed
or on the ground it just holds where it is. `stop.stop_time`: seconds from entry to stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.stopping import StoppingMode

BRAKE_MODE_DECEL_RATE = 750.0    # cm/s/s


class ModeBrake(StoppingMode):
    number = modes.BRAKE
    position_required, arming_allowed = True, False

    def stop_limits(self) -> tuple[float, float]:
        return BRAKE_MODE_DECEL_RATE / 100.0, float(self.ap.params.get("PSC_JERK_XY", 5.0))
