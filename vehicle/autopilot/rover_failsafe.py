"""What a rover does on a failsafe (Rover/failsafe.cpp, fence.cpp); failsafe.py decides when.

- GCS: FS_ACTION 0 "GCS Failsafe" only; 1 RTL, 2 Hold, 3 SmartRTL->RTL->Hold, 4 SmartRTL->Hold
  (HOLD when none starts), said as "GCS Failsafe On: <RTL|SmartRTL|Hold>".
- Battery, BATT_FS_*_ACT: 1 RTL or Hold, 2 Hold, 3 SmartRTL or RTL or Hold, 4 SmartRTL or
  Hold, 5 Terminate (disarm).
- Fence, FENCE_ACTION: as FS_ACTION 1..4.
- Radio (radio_failsafe.py decides when), FS_ACTION: as the GCS failsafe's, 5 disarms.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot import modes
from vehicle.autopilot.failsafe import Failsafes

TRIES = {1: (modes.ROVER_RTL,), 3: (modes.ROVER_SMART_RTL, modes.ROVER_RTL), 4: (modes.ROVER_SMART_RTL,)}
TERMINATE = 5
SAID = {modes.ROVER_RTL: "RTL", modes.ROVER_SMART_RTL: "SmartRTL"}


class RoverFailsafes(Failsafes):
    # ArduRover's FailsafeAction priorities, highest first: Terminate, Hold, RTL,
    # SmartRTL_Hold, SmartRTL, None
    priorities = (5, 2, 1, 4, 3, 0)

    def _action_mode(self, action: int, reason: str) -> int:
        """FS_ACTION / FENCE_ACTION's modes, then HOLD: the mode it got into."""
        for m in TRIES.get(action, ()) + (modes.ROVER_HOLD,):
            if self.ap.set_mode(m, reason):
                return m
        return self.ap.mode

    def gcs_action(self, enable: int) -> None:
        ap = self.ap
        action = int(ap.params.get("FS_ACTION", 2))
        if action == 0:
            ap.text(mav.MAV_SEVERITY_WARNING, "GCS Failsafe")
            return
        got = self._action_mode(action, "GCS failsafe")
        ap.text(mav.MAV_SEVERITY_WARNING, f"GCS Failsafe On: {SAID.get(got, 'Hold')}")

    def radio_action(self, action: int) -> None:
        """FS_ACTION on a radio failsafe (radio_failsafe.py): 0 nothing, 5 disarm, else as
        the GCS failsafe's modes."""
        if action == TERMINATE:
            self.ap.disarm(force=True)
        elif action:
            self._action_mode(action, "radio failsafe")

    def battery_action(self, action: int) -> None:
        if action == TERMINATE:
            self.ap.disarm(force=True)
            return
        chain = {1: (modes.ROVER_RTL, modes.ROVER_HOLD), 2: (modes.ROVER_HOLD,),
                 3: (modes.ROVER_SMART_RTL, modes.ROVER_RTL, modes.ROVER_HOLD),
                 4: (modes.ROVER_SMART_RTL, modes.ROVER_HOLD)}.get(action, ())
        self.first_mode(chain, "battery failsafe")

    def fence_action(self, action: int, far_outside: bool) -> None:
        """far_outside is the copter's: a rover acts the same however far out it is."""
        self._action_mode(action, "fence breach")
