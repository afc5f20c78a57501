"""BRAKE (ArduCopter/mode_brake.cpp ModeBrake): stops as fast as it may, then holds.

Horizontal deceleration BRAKE_MODE_DECEL_RATE (750 cm/s/s, ArduCopter's config.h) reached at
PSC_JERK_XY, altitude held (stopping.py); once stopped it holds that point. Entered disarmed
or on the ground it just holds where it is. `stop.stop_time`: seconds from entry to stopped.
"""
from __future__ import annotations

from vehicle.autopilot import modes
from vehicle.autopilot.copter_modes.copter_mode import CopterMode
from vehicle.autopilot.copter_modes.stopping import StopThenHold
from vehicle.autopilot.mode import ArmingMethod

BRAKE_MODE_DECEL_RATE = 750.0    # cm/s/s


class ModeBrake(CopterMode):
    number = modes.BRAKE

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.stop = StopThenHold(ap)

    def requires_position(self) -> bool:
        return True

    def allows_arming(self, method: ArmingMethod) -> bool:
        return False

    def enter(self) -> None:
        ap = self.ap
        if ap.armed and not ap.on_ground:          # else nothing to stop: hold where it is
            self.stop.start(BRAKE_MODE_DECEL_RATE / 100.0, float(ap.params.get("PSC_JERK_XY", 5.0)))

    def exit(self) -> None:
        super().exit()
        self.stop.release()

    def fly(self, dt: float) -> None:
        self.stop.run(dt)
