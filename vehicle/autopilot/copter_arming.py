"""A copter's arming (AP_Arming_Copter): it refuses an unforced disarm in the air ("Disarm:
not landed"); arming starts the DISARM_DELAY clock (AUTO's takeoff auto-arms with
AUTO_OPTIONS bit 1: copter_modes/auto.py); disarming stops any user takeoff and the motors
(no setpoint)."""
from __future__ import annotations

from vehicle.autopilot.arming import Arming


class CopterArming(Arming):
    disarm_refused = "Disarm: not landed"

    def may_disarm(self) -> bool:
        return self.ap.on_ground

    def on_armed(self) -> None:
        ap = self.ap
        ap.landed_since = ap.t

    def on_disarmed(self) -> None:
        self.ap.takeoff.stop()
        self.ap.setpoint()
