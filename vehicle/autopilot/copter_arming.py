"""A copter's arming (AP_Arming_Copter): it refuses an unforced disarm in the air ("Disarm:
not landed"); arming starts the DISARM_DELAY clock (AUTO's takeoff auto-arms with
AUTO_OPTIONS bit 1: copter_modes/auto.py); disarming stops any user takeoff and the motors
(no setpoint).

The throttle checks (ARMING_CHECK on, once there is RC input: rc_input.py): pre-arm
"Throttle below failsafe" (FS_THR_ENABLE on and the throttle under FS_THR_VALUE); arm
"Throttle too high" when the throttle asks for a climb (above THR_DZ about mid stick), or in
a manual-throttle mode (STABILIZE) is above zero; not checked when the GCS arms in GUIDED,
GUIDED_NOGPS or an AUTO that allows arming (allows_GCS_or_SCR_arming_with_throttle_high).
"""
from __future__ import annotations

from vehicle.autopilot import copter_pilot
from vehicle.autopilot.arming import Arming


class CopterArming(Arming):
    disarm_refused = "Disarm: not landed"

    def prearm_failures(self) -> list[str]:
        out = super().prearm_failures()
        ap = self.ap
        if (out or ap.params.get("ARMING_CHECK", 1) == 0 or ap.rc.sticks is None
                or int(ap.params.get("FS_THR_ENABLE", 1)) == 0):
            return out
        if ap.rc.sticks.throttle_pwm < int(ap.params.get("FS_THR_VALUE", 975)):
            out.append("Throttle below failsafe")
        return out

    def arm_check_failure(self) -> str:
        ap = self.ap
        s = ap.rc.sticks
        if s is None or ap.params.get("ARMING_CHECK", 1) == 0:
            return ""
        mode = ap.flightmode
        if mode.allows_arming_with_throttle_high():
            return ""
        if copter_pilot.climb_rate(s, ap.params) > 0.0 or (mode.has_manual_throttle() and s.throttle > 0):
            return "Throttle too high"
        return ""

    def may_disarm(self) -> bool:
        return self.ap.on_ground

    def on_armed(self) -> None:
        ap = self.ap
        ap.landed_since = ap.t

    def on_disarmed(self) -> None:
        self.ap.takeoff.stop()
        self.ap.setpoint()
