"""The simulated battery and ArduPilot's battery monitor and failsafe (pure: no clocks, no I/O).

Pack (the hardware; SIM_BATT_VOLTAGE, SIM_BATT_CAP_AH or BATT_CAPACITY)
- A LiPo of round(SIM_BATT_VOLTAGE / 4.2) cells. Open-circuit voltage from the state of charge
  by a typical LiPo discharge curve (OCV_CURVE, per cell, scaled so full = SIM_BATT_VOLTAGE).
- Voltage under load, the stated model: V = OCV(soc) - I * R, R = CELL_RESISTANCE per cell
  (internal resistance plus wiring). The current follows from the electrical power the
  vehicle draws, P = V * I, solved exactly: I = (OCV - sqrt(OCV^2 - 4 R P)) / (2 R).
- The power: AVIONICS_W always (flight controller, GPS, radio), plus the load the autopilot
  reports (a copter: its rotors' shaft power, physics.multicopter.rotor_power, divided by
  the motor and ESC efficiency; a rover: its drive), so it drains with thrust.
- A reboot does not recharge it (reboot() resets only the monitor, as on a real vehicle).

Monitor (AP_BattMonitor; BATT_MONITOR 0 none, 3 voltage only, 4 voltage and current)
- consumed mAh and Wh integrate the current; remaining % = 100 (1 - consumed / BATT_CAPACITY);
  time remaining = remaining capacity / the current averaged over AVG_TAU.
- Failsafe, checked while armed as AP_BattMonitor_Backend::update_failsafes: critical before
  low; a voltage below BATT_CRT_VOLT / BATT_LOW_VOLT (raw, or the resting estimate V + I R
  with BATT_FS_VOLTSRC 1) must last BATT_LOW_TIMER seconds (0 disables the voltage
  failsafe); remaining capacity below BATT_CRT_MAH / BATT_LOW_MAH triggers at once (current
  monitoring only). Levels only rise: once low, only critical triggers again.
"""
from __future__ import annotations

import math
from bisect import bisect_left
from collections.abc import Mapping
from dataclasses import dataclass

NONE, LOW, CRITICAL = 0, 1, 2
LEVEL_NAMES = {LOW: "low", CRITICAL: "critical"}

# state of charge % -> open-circuit cell voltage (V): a typical LiPo discharge curve
OCV_CURVE = ((0, 3.27), (5, 3.61), (10, 3.69), (15, 3.71), (20, 3.73), (30, 3.77), (40, 3.79),
             (50, 3.82), (60, 3.87), (70, 3.93), (80, 4.02), (90, 4.08), (100, 4.20))
CELL_FULL = 4.2            # V
CELL_RESISTANCE = 0.012    # ohm per cell, internal + wiring (a 3S 3300 mAh 35C pack: 36 mOhm)
AVIONICS_W = 3.5           # W drawn whenever powered (about 0.3 A at 11.1 V)
MOTOR_EFFICIENCY = 0.8     # shaft power / electrical power of motors and ESCs
AVG_TAU = 10.0             # s: current average for time_remaining


_OCV_TOPS = [s1 for s1, _ in OCV_CURVE[1:]]          # upper end of each curve segment
_OCV_SEGMENTS = list(zip(OCV_CURVE, OCV_CURVE[1:]))


def cell_ocv(soc_pct: float) -> float:
    """Open-circuit voltage of one cell (V) at soc_pct % (clamped to 0..100)."""
    s = min(100.0, max(0.0, soc_pct))
    k = bisect_left(_OCV_TOPS, s)                      # the first segment with s <= its top
    if k == len(_OCV_SEGMENTS):
        return OCV_CURVE[-1][1]
    (s0, v0), (s1, v1) = _OCV_SEGMENTS[k]
    return v0 + (v1 - v0) * (s - s0) / (s1 - s0)


@dataclass
class BatteryReading:
    """What the monitor reports (None where the monitor type cannot measure it)."""
    voltage: float | None            # V
    current: float | None            # A
    consumed_mah: float | None
    consumed_wh: float | None
    remaining_pct: int | None        # 0..100
    time_remaining: int | None       # s
    failsafe: int                    # NONE / LOW / CRITICAL


class Battery:
    """One pack and its monitor. update(dt, load_w, armed, params) once per autopilot tick;
    it returns the failsafe level that has just been reached (LOW / CRITICAL) or NONE."""

    def __init__(self) -> None:
        self.pack_used_mah = 0.0      # charge taken from the pack (hardware)
        self.consumed_mah = 0.0       # what the monitor has counted since boot
        self.consumed_wh = 0.0
        self.current = 0.0            # A
        self.voltage = 0.0            # V at the terminals, under load
        self.resting_voltage = 0.0    # V + I R
        self.avg_current = 0.0
        self.failsafe = NONE
        self._low_since: float | None = None
        self._crit_since: float | None = None
        self.t = 0.0

    _pack_key: tuple | None = None
    _pack_cfg: tuple[float, int, float] = (0.0, 1, 1.0)
    _avg_dt: float | None = None
    _avg_k = 0.0

    def reboot(self) -> None:
        """The autopilot restarts: its monitor counts from zero, the pack keeps its charge."""
        self.consumed_mah = self.consumed_wh = 0.0
        self.avg_current = 0.0
        self.failsafe = NONE
        self._low_since = self._crit_since = None

    # ---- the pack ------------------------------------------------------------------------
    @staticmethod
    def _pack(p: Mapping[str, float]) -> tuple[float, int, float]:
        """(full voltage, cells, capacity mAh) of the simulated pack."""
        full = float(p.get("SIM_BATT_VOLTAGE", 12.6)) or 12.6
        cells = max(1, int(round(full / CELL_FULL)))
        cap_ah = float(p.get("SIM_BATT_CAP_AH", 0.0))
        cap = cap_ah * 1000.0 if cap_ah > 0 else float(p.get("BATT_CAPACITY", 3300)) or 3300.0
        return full, cells, cap

    def soc(self, p: Mapping[str, float]) -> float:
        """True state of charge of the pack, %."""
        _, _, cap = self._pack(p)
        return max(0.0, 100.0 * (1.0 - self.pack_used_mah / cap))

    def update(self, t: float, dt: float, load_w: float, armed: bool, p: Mapping[str, float]) -> int:
        """Advance by dt seconds drawing load_w watts (on top of the avionics); returns the
        failsafe level reached now (NONE if none was)."""
        self.t = t
        g = p.get
        key = (g("SIM_BATT_VOLTAGE", 12.6), g("SIM_BATT_CAP_AH", 0.0), g("BATT_CAPACITY", 3300))
        if key != self._pack_key:             # the pack's figures, re-derived when they change
            self._pack_key, self._pack_cfg = key, self._pack(p)
        full, cells, cap = self._pack_cfg
        ocv = full * cell_ocv(max(0.0, 100.0 * (1.0 - self.pack_used_mah / cap))) / CELL_FULL   # soc(p)
        r = CELL_RESISTANCE * cells
        power = AVIONICS_W + max(0.0, float(load_w) if math.isfinite(load_w) else 0.0)
        disc = ocv * ocv - 4.0 * r * power
        # beyond the pack's maximum power (disc < 0) it delivers that maximum: I = OCV / 2R
        i = (ocv - math.sqrt(disc)) / (2.0 * r) if disc > 0 else ocv / (2.0 * r)
        if self.pack_used_mah >= cap:
            i = 0.0                    # flat: nothing left to give
        self.current = i
        self.voltage = max(0.0, ocv - i * r)
        self.resting_voltage = ocv
        dt = max(0.0, dt)
        mah = i * dt / 3.6
        self.pack_used_mah += mah
        self.consumed_mah += mah
        self.consumed_wh += self.voltage * i * dt / 3600.0
        if dt != self._avg_dt:                 # the tick is fixed: one exp per tick length
            self._avg_dt, self._avg_k = dt, (1.0 - math.exp(-dt / AVG_TAU) if dt > 0 else 0.0)
        k = self._avg_k
        self.avg_current += (i - self.avg_current) * k
        return self._check_failsafe(t, armed, p)

    # ---- the monitor ---------------------------------------------------------------------
    @staticmethod
    def monitor_type(p: Mapping[str, float]) -> int:
        return int(p.get("BATT_MONITOR", 4))

    def has_current(self, p: Mapping[str, float]) -> bool:
        return self.monitor_type(p) not in (0, 3)

    def remaining_pct(self, p: Mapping[str, float]) -> int | None:
        if not self.has_current(p):
            return None
        cap = float(p.get("BATT_CAPACITY", 3300))
        if cap <= 0:
            return None
        return int(round(max(0.0, min(100.0, 100.0 * (1.0 - self.consumed_mah / cap)))))

    def reading(self, p: Mapping[str, float]) -> BatteryReading:
        """What BATTERY_STATUS / SYS_STATUS report now."""
        if self.monitor_type(p) == 0:
            return BatteryReading(None, None, None, None, None, None, NONE)
        cur = self.has_current(p)
        rem = self.remaining_pct(p)
        tr = None
        if cur and self.avg_current > 0.1:
            left = max(0.0, float(p.get("BATT_CAPACITY", 3300)) - self.consumed_mah)
            tr = int(left / 1000.0 / self.avg_current * 3600.0)
        return BatteryReading(self.voltage, self.current if cur else None, self.consumed_mah if cur else None,
                              self.consumed_wh if cur else None, rem, tr, self.failsafe)

    def _check_failsafe(self, t: float, armed: bool, p: Mapping[str, float]) -> int:
        # runs every tick for every vehicle: each parameter is read once, capacity only armed
        g = p.get
        monitor = int(g("BATT_MONITOR", 4))
        if monitor == 0:
            return NONE
        v = self.resting_voltage if int(g("BATT_FS_VOLTSRC", 0)) == 1 else self.voltage
        low_volt, crt_volt = float(g("BATT_LOW_VOLT", 10.5)), float(g("BATT_CRT_VOLT", 0))
        low_v = v > 0 and low_volt > 0 and v < low_volt
        crt_v = v > 0 and crt_volt > 0 and v < crt_volt
        # the voltage timers run whether armed or not; the failsafe is only raised armed
        self._crit_since = (self._crit_since if self._crit_since is not None else t) if crt_v else None
        self._low_since = (self._low_since if self._low_since is not None else t) if low_v else None
        if not armed:
            return NONE
        # capacity: current monitoring only (BATT_MONITOR 3 is voltage only)
        cur = monitor != 3
        low_mah, crt_mah = float(g("BATT_LOW_MAH", 0)), float(g("BATT_CRT_MAH", 0))
        left = float(g("BATT_CAPACITY", 3300)) - self.consumed_mah
        low_c = cur and low_mah > 0 and left < low_mah
        crt_c = cur and crt_mah > 0 and left < crt_mah
        timer = float(g("BATT_LOW_TIMER", 10))
        level = NONE
        if (crt_v and timer > 0 and t - self._crit_since > timer) or crt_c:
            level = CRITICAL
        elif (low_v and timer > 0 and t - self._low_since > timer) or low_c:
            level = LOW
        if level <= self.failsafe:
            return NONE
        self.failsafe = level
        return level

    def failsafe_text(self) -> str:
        """AP_BattMonitor's STATUSTEXT (MAV_SEVERITY_WARNING) for the level just reached."""
        return (f"Battery 1 is {LEVEL_NAMES.get(self.failsafe, 'low')} {self.voltage:.2f}V "
                f"used {self.consumed_mah:.0f} mAh")


def action_priority(action: int, priorities: tuple[int, ...]) -> int:
    """Index of `action` in the vehicle's failsafe priority list (highest first); an action
    not listed ranks after all of them, as ArduPilot's search to the list's end."""
    return priorities.index(action) if action in priorities else len(priorities)
