"""What a copter does on a failsafe (ArduCopter/events.cpp, fence.cpp); failsafe.py decides
when. Landed with no takeoff under way, every failsafe disarms instead.

- GCS, FS_GCS_ENABLE: 1, 2, 6 RTL (LAND if RTL cannot start); 3 SmartRTL, else RTL, else
  LAND; 4 SmartRTL, else LAND; 5 LAND.
- Battery, BATT_FS_*_ACT ("Battery Failsafe"): 1 Land, 2 RTL or Land, 3 SmartRTL or RTL or
  Land, 4 SmartRTL or Land, 5 Terminate (disarm), 6 DO_LAND_START or RTL (no landing
  sequence here: RTL or Land), 7 Brake or Land.
- Fence, FENCE_ACTION: 1 RTL or LAND, 2 LAND, 3 SmartRTL or RTL or LAND, 4 BRAKE or LAND,
  5 SmartRTL or LAND; more than 100 m outside: LAND.
Every failsafe LAND but the fence's is ArduCopter's set_mode_land_with_pause (land_with_pause
here, also for the radio and EKF failsafes): LAND holds its altitude LAND_WITH_DELAY_S before
descending (copter_modes/land.py); a BRAKE that cannot start says "Trying Land Mode" first.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.failsafe import Failsafes

SEV_WARNING = mav.MAV_SEVERITY_WARNING
BATTERY_CHAINS = {1: (modes.LAND,), 2: (modes.RTL, modes.LAND), 3: (modes.SMART_RTL, modes.RTL, modes.LAND),
                  4: (modes.SMART_RTL, modes.LAND), 6: (modes.RTL, modes.LAND), 7: (modes.BRAKE, modes.LAND)}
TERMINATE = 5


class CopterFailsafes(Failsafes):
    # ArduCopter's FailsafeAction priorities, highest first: TERMINATE, LAND, RTL,
    # SMARTRTL_LAND, SMARTRTL, NONE
    priorities = (5, 1, 2, 4, 3, 0)

    def _landed(self) -> bool:
        return self.ap.on_ground and not self.ap.takeoff.running

    def gcs_action(self, enable: int) -> None:
        ap = self.ap
        why = "GCS failsafe"
        if self._landed():
            ap.text(SEV_WARNING, "GCS Failsafe")
            ap.disarm(force=True, reason=why)
        elif enable == 5:
            ap.text(SEV_WARNING, "GCS Failsafe On: LAND")
            self.land_with_pause(why)
        elif enable == 3:
            ap.text(SEV_WARNING, "GCS Failsafe On: SmartRTL")
            if not self.smart_rtl_or_rtl(why):
                self.land_with_pause(why)
        elif enable == 4:
            ap.text(SEV_WARNING, "GCS Failsafe On: SmartRTL")
            self.smart_rtl_or_land(why)
        else:
            ap.text(SEV_WARNING, "GCS Failsafe On: RTL")
            self.failsafe_modes((modes.RTL, modes.LAND), why)

    def battery_action(self, action: int) -> None:
        ap = self.ap
        if self._landed():
            ap.disarm(force=True)
            ap.text(SEV_WARNING, "Battery Failsafe - Disarming")
            return
        ap.text(SEV_WARNING, "Battery Failsafe")
        if action == TERMINATE:
            ap.disarm(force=True)
            return
        self.failsafe_modes(BATTERY_CHAINS.get(action, ()), "battery failsafe")

    def fence_action(self, action: int, far_outside: bool) -> None:
        ap = self.ap
        why = "fence breach"
        if ap.on_ground:
            ap.disarm(force=True, reason=why)
        elif far_outside or action == 2:
            ap.set_mode(modes.LAND, why)
        elif action == 3:
            if not self.smart_rtl_or_rtl(why):
                ap.set_mode(modes.LAND, why)
        elif action == 4:
            self.first_mode((modes.BRAKE, modes.LAND), why)
        elif action == 5:
            self.smart_rtl_or_land(why, pause=False)
        else:
            self.first_mode((modes.RTL, modes.LAND), why)

    def smart_rtl_or_rtl(self, reason: str) -> bool:
        """ArduCopter's set_mode_SmartRTL_or_RTL: SMART_RTL, else RTL with its text."""
        if self.ap.set_mode(modes.SMART_RTL, reason):
            return True
        self.ap.text(SEV_WARNING, "SmartRTL Unavailable, Trying RTL Mode")
        return self.ap.set_mode(modes.RTL, reason)

    def smart_rtl_or_land(self, reason: str, pause: bool = True) -> bool:
        """ArduCopter's set_mode_SmartRTL_or_land_with_pause: SMART_RTL, else LAND with its text
        (pause=False: the fence's, a LAND without the pause)."""
        if self.ap.set_mode(modes.SMART_RTL, reason):
            return True
        self.ap.text(SEV_WARNING, "SmartRTL Unavailable, Using Land Mode")
        return self.land_with_pause(reason) if pause else self.ap.set_mode(modes.LAND, reason)

    def land_with_pause(self, reason: str) -> bool:
        """ArduCopter's set_mode_land_with_pause: LAND, its descent held for LAND_WITH_DELAY_S
        after LAND was entered (copter_modes/land.py)."""
        ok = self.ap.set_mode(modes.LAND, reason)
        self.ap.flightmodes[modes.LAND].set_land_pause(True)
        return ok

    def failsafe_modes(self, numbers, reason: str) -> bool:
        """The first of `numbers` that starts, as first_mode, a LAND with the pause; a BRAKE
        that does not start says "Trying Land Mode" (set_mode_brake_or_land_with_pause)."""
        for m in numbers:
            if m == modes.LAND:
                return self.land_with_pause(reason)
            if self.ap.set_mode(m, reason):
                return True
            if m == modes.BRAKE:
                self.ap.text(SEV_WARNING, "Trying Land Mode")
        return False
