"""The failsafes of one autopilot: when the GCS, battery and fence failsafes trigger (here) and
what the vehicle does then (its subclass: copter_failsafe.py, rover_failsafe.py).

- GCS: FS_GCS_ENABLE != 0, armed, a GCS heard once, then silent for FS_GCS_TIMEOUT s (sim
  time): the action once; "GCS Failsafe Cleared" at the next heartbeat.
- Battery (battery.py is the pack and AP_BattMonitor): read at 10 Hz, as ArduCopter's
  update_batt_compass and ArduRover's AP_BattMonitor::read; a new failsafe level says so in
  AP_BattMonitor's words and takes BATT_FS_LOW_ACT / BATT_FS_CRT_ACT if that action ranks at
  or above the one already taken (the vehicle's priority list, highest first).
- Fence (fence.py decides the breach): FENCE_ACTION, and whether the copter is more than
  100 m outside.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.battery import CRITICAL, action_priority

BATTERY_PERIOD = 0.1     # s: ArduPilot reads its battery monitor at 10 Hz


class Failsafes:
    """GCS and battery failsafe triggers; subclasses act (gcs_action, battery_action,
    fence_action) and rank the battery actions (`priorities`)."""

    priorities: tuple[int, ...] = ()      # BATT_FS_*_ACT values, highest priority first

    def __init__(self, ap) -> None:
        self.ap = ap
        self.last_gcs: float | None = None      # sim s of the last GCS heartbeat
        self.gcs_failsafe = False
        self._battery_due = 0.0                 # sim s since the monitor was last read
        self.battery_priority: int | None = None

    def update(self, t: float, dt: float) -> None:
        """Every autopilot tick: the battery (read every BATTERY_PERIOD), then the GCS.
        Inline: it runs every tick for every vehicle, and nothing triggers on most."""
        self._battery_due += dt
        if self._battery_due >= BATTERY_PERIOD - 1e-9 or dt <= 0:
            self._battery(t)
        ap = self.ap
        if self.last_gcs is None or self.gcs_failsafe or not ap.armed:
            return
        enable = int(ap.params.get("FS_GCS_ENABLE", 0))
        if enable and ap.t - self.last_gcs > float(ap.params.get("FS_GCS_TIMEOUT", 5.0)):
            self.gcs_failsafe = True
            ap.rc.clear_overrides()          # RC control goes back to the radio
            self.gcs_action(enable)

    # ----- GCS ----------------------------------------------------------------------------
    def gcs_heartbeat(self) -> None:
        ap = self.ap
        self.last_gcs = ap.t
        if self.gcs_failsafe:
            self.gcs_failsafe = False
            ap.text(mav.MAV_SEVERITY_INFO, "GCS Failsafe Cleared")

    # ----- battery ------------------------------------------------------------------------
    def _battery(self, t: float) -> None:
        # the load drawn at the reading stands for the time since the last one (0.1 s)
        dt, self._battery_due = self._battery_due, 0.0
        ap = self.ap
        b = ap.battery
        level = b.update(t, dt, ap.electrical_load() if ap.armed else 0.0, ap.armed, ap.params.values)
        if not level:
            return
        ap.text(mav.MAV_SEVERITY_WARNING, b.failsafe_text())
        action = int(ap.params.get("BATT_FS_CRT_ACT" if level == CRITICAL else "BATT_FS_LOW_ACT", 0))
        prio = action_priority(action, self.priorities)
        if self.battery_priority is None or prio <= self.battery_priority:
            self.battery_priority = prio
            self.battery_action(action)

    # ----- what the vehicle does --------------------------------------------------------
    def gcs_action(self, enable: int) -> None:
        """FS_GCS_ENABLE's action (the GCS has been silent too long)."""
        raise NotImplementedError

    def battery_action(self, action: int) -> None:
        """BATT_FS_LOW_ACT / BATT_FS_CRT_ACT."""
        raise NotImplementedError

    def fence_action(self, action: int, far_outside: bool) -> None:
        """FENCE_ACTION for a new breach while armed (far_outside: more than 100 m out)."""
        raise NotImplementedError

    def first_mode(self, numbers, reason: str) -> bool:
        """Stay in, or change to, the first of `numbers` that will start; False if none does."""
        return any(self.ap.set_mode(m, reason) for m in numbers)
