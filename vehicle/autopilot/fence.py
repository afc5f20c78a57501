"""The geofence of one autopilot: parameters, breaches, the breach action, GUIDED destinations.

ArduPilot's AC_Fence and the vehicles' fence_check (learned from their source):
- checked at the vehicle's fence_check scheduler rate: 25 Hz copter, 10 Hz rover (update);
- FENCE_ENABLE 0/1 (also MAV_CMD_DO_FENCE_ENABLE); FENCE_TYPE bits: 1 max altitude,
  2 circle around home (FENCE_RADIUS, default 300 m), 4 inclusion/exclusion polygons and
  circles from the FENCE list, 8 min altitude (copter; rover has only 2 and 4). FENCE_ALT_MAX
  100 m, FENCE_ALT_MIN -10 m (above home; this floor arms itself once the vehicle is
  FENCE_MARGIN above it, "Min Alt fence enabled (auto enable)", and is off while landing
  and on the ground),
  FENCE_MARGIN 2 m (pre-arm checks and the floor; ArduPilot also uses it for avoidance, which
  towerlink does not model).
- A breach is new when a fence type goes from clear to breached; a "backup" fence 20 m
  further out (altitude and circle) makes a further breach new again.
- New breaches while armed say "<Max Alt|Circle|Polygon|Min Alt> fence breached"
  (NOTICE, names joined with ", " and " and ", "fences" for several; the copter keeps
  quiet when landed), then FENCE_ACTION (0 report only) as the vehicle's failsafe acts on it
  (copter_failsafe.py: more than 100 m outside forces LAND, landed -> disarm;
  rover_failsafe.py).
- Pre-arm (only with FENCE_ENABLE 1): "Fences enabled, but none selected",
  "Polygon fence(s) invalid", "Polygon fence margin is less than inclusion circle radius",
  "FENCE_ALT_MAX < FENCE_ALT_MIN", "FENCE_MARGIN too big" (altitudes closer than two
  margins), "Vehicle breaching <names>".
- Copter GUIDED destinations outside an enabled fence are refused (ArduCopter only logs
  DEST_OUTSIDE_FENCE: the vehicle keeps its previous target; copter_modes/guided.py). Velocity
  and acceleration targets are not destinations: they may cross, and the breach acts.
- SYS_STATUS geofence bits: present (a fence type configured), enabled (FENCE_ENABLE and an
  action other than report-only), healthy (no breach).
"""
from __future__ import annotations

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.fence_geometry import FenceLoadError, FenceZones, load_zones
from vehicle.autopilot.mission_store import FENCE
from vehicle.autopilot.task_rate import TaskRate

ALT_MAX, CIRCLE, POLYGON, ALT_MIN = 1, 2, 4, 8
NAMES = ((ALT_MAX, "Max Alt"), (CIRCLE, "Circle"), (POLYGON, "Polygon"), (ALT_MIN, "Min Alt"))
BACKUP_M = 20.0
FORCE_LAND_M = 100.0
# Hz: the vehicles' fence_check scheduler task (ArduCopter/Copter.cpp 25, Rover/Rover.cpp 10)
CHECK_RATE = {"copter": 25.0, "rover": 10.0}


def fence_names(mask: int) -> str:
    """AC_Fence's wording: "Circle fence", "Max Alt and Circle fences", ..."""
    names = [n for bit, n in NAMES if mask & bit]
    if not names:
        return ""
    text = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    return text + (" fences" if len(names) > 1 else " fence")


class Fence:
    def __init__(self, ap) -> None:
        self.ap = ap
        self.breaches = 0
        self.breach_count = 0             # AC_Fence's: one per new breach (FENCE_STATUS)
        self.breach_time = 0.0            # sim s of the last breach that began from none
        self.alt_max_backup = 0.0
        self.circle_backup = 0.0
        self.breach_distance = 0.0
        self.floor_enabled = False        # the Min Alt fence arms itself once above it (AC_Fence)
        self._zones: FenceZones | None = None
        self._zones_version = -1
        self._zones_error: str | None = None
        self._check_task = TaskRate(CHECK_RATE[ap.kind])

    # ----- configuration -------------------------------------------------------------
    def enabled(self) -> bool:
        return int(self.ap.params.get("FENCE_ENABLE", 0)) == 1

    def types(self) -> int:
        mask = int(self.ap.params.get("FENCE_TYPE", 7))
        return mask if self.ap.kind == "copter" else mask & (CIRCLE | POLYGON)

    def zones(self) -> FenceZones | None:
        """The FENCE list's zones (cached per store version); None if invalid."""
        store = self.ap.missions
        if store.version[FENCE] != self._zones_version:
            self._zones_version = store.version[FENCE]
            try:
                self._zones, self._zones_error = load_zones(store.items(FENCE), self.ap.origin), None
            except FenceLoadError as e:
                self._zones, self._zones_error = None, str(e)
        return self._zones

    def present(self) -> int:
        mask = CIRCLE | ALT_MIN | ALT_MAX
        z = self.zones()
        if z is not None and z.count() > 0:
            mask |= POLYGON
        return self.types() & mask

    def active(self) -> int:
        if not self.enabled():
            return 0
        mask = self.present()
        return mask if self.floor_enabled else mask & ~ALT_MIN

    def set_enabled(self, on: bool) -> None:
        """MAV_CMD_DO_FENCE_ENABLE: runtime switch (not saved, as ArduPilot)."""
        self.ap.params.set("FENCE_ENABLE", 1.0 if on else 0.0, save=False)
        if not on:
            self.breaches = 0

    # ----- geometry -------------------------------------------------------------------
    def _home(self) -> np.ndarray:
        ap = self.ap
        return ap.home if ap.home is not None else ap.start_ned

    def breached_at(self, ned, mask: int | None = None) -> int:
        """Fence types (of `mask`, default the active ones) the world NED point breaches."""
        mask = self.active() if mask is None else mask
        home = self._home()
        p = np.asarray(ned, float)
        out = 0
        alt = float(home[2] - p[2])
        if mask & ALT_MAX and alt >= float(self.ap.params.get("FENCE_ALT_MAX", 100)):
            out |= ALT_MAX
        if mask & ALT_MIN and alt <= float(self.ap.params.get("FENCE_ALT_MIN", -10)):
            out |= ALT_MIN
        if mask & CIRCLE and np.linalg.norm(p[:2] - home[:2]) >= float(self.ap.params.get("FENCE_RADIUS", 300)):
            out |= CIRCLE
        if mask & POLYGON:
            z = self.zones()
            if z is not None and z.breached(p[:2]):
                out |= POLYGON
        return out

    def destination_ok(self, ned) -> bool:
        """AC_Fence::check_destination_within_fence: False if the point is outside an active fence."""
        return self.breached_at(ned) == 0

    # ----- checks ---------------------------------------------------------------------
    def prearm_failure(self) -> str | None:
        if not self.enabled():
            return None
        if not self.present():
            return "Fences enabled, but none selected"
        p = self.ap.params
        margin = float(p.get("FENCE_MARGIN", 2))
        types = self.types()
        if types & POLYGON:
            z = self.zones()
            if z is None:
                return "Polygon fence(s) invalid"
            if any(r < margin for _, r in z.inclusion_circles):
                return "Polygon fence margin is less than inclusion circle radius"
        if types & CIRCLE and float(p.get("FENCE_RADIUS", 300)) < margin:
            return "Circle FENCE_MARGIN is less than FENCE_RADIUS"
        if self.ap.kind == "copter":
            alt_max, alt_min = float(p.get("FENCE_ALT_MAX", 100)), float(p.get("FENCE_ALT_MIN", -10))
            if alt_max < alt_min:
                return "FENCE_ALT_MAX < FENCE_ALT_MIN"
            if alt_max - alt_min <= 2 * margin:
                return "FENCE_MARGIN too big"
        b = self.breached_at(self.ap.pos)
        if b:
            return f"Vehicle breaching {fence_names(b)}"
        return None

    def update(self, t: float) -> None:
        """Every autopilot tick: check() at the vehicle's fence_check rate (CHECK_RATE)."""
        if self._check_task.due(t):
            self.check(t)

    def check(self, t: float) -> None:
        """Periodic: record breaches, and act on new ones while armed."""
        ap = self.ap
        self._auto_floor()
        active = self.active()
        if not active:
            self.breaches = 0
            return
        now = self.breached_at(ap.pos, active)
        new = now & ~self.breaches
        home = self._home()
        alt = float(home[2] - ap.pos[2])
        dist = float(np.linalg.norm(ap.pos[:2] - home[:2]))
        # a backup fence further out turns a continuing breach into a new one
        if now & ALT_MAX and self.breaches & ALT_MAX and self.alt_max_backup and alt >= self.alt_max_backup:
            new |= ALT_MAX
        if now & CIRCLE and self.breaches & CIRCLE and self.circle_backup and dist >= self.circle_backup:
            new |= CIRCLE
        if new & ALT_MAX:
            self.alt_max_backup = alt + BACKUP_M
        if new & CIRCLE:
            self.circle_backup = dist + BACKUP_M
        self.breach_distance = max(alt - float(ap.params.get("FENCE_ALT_MAX", 100)) if now & ALT_MAX else 0.0,
                                   dist - float(ap.params.get("FENCE_RADIUS", 300)) if now & CIRCLE else 0.0)
        if new:
            if not self.breaches:
                self.breach_time = t
            self.breach_count += bin(new).count("1")
        self.breaches = now
        if not now & ALT_MAX:
            self.alt_max_backup = 0.0
        if not now & CIRCLE:
            self.circle_backup = 0.0
        if new and ap.armed:
            self.act(new)

    def _auto_floor(self) -> None:
        """AC_Fence: the Min Alt fence is enabled once the vehicle is FENCE_MARGIN above it, and
        disabled again on the ground (landing)."""
        ap = self.ap
        if ap.on_ground or not ap.armed or ap.landed_state() == mav.MAV_LANDED_STATE_LANDING:
            self.floor_enabled = False          # landing (LAND, RTL's or AUTO's descent) goes through it
            return
        if self.floor_enabled or not (self.enabled() and self.types() & ALT_MIN):
            return
        home = self._home()
        alt = float(home[2] - ap.pos[2])
        p = ap.params
        if alt >= float(p.get("FENCE_ALT_MIN", -10)) + float(p.get("FENCE_MARGIN", 2)):
            self.floor_enabled = True
            ap.text(mav.MAV_SEVERITY_NOTICE, "Min Alt fence enabled (auto enable)")

    def act(self, new: int) -> None:
        ap = self.ap
        copter = ap.kind == "copter"
        if not (copter and ap.on_ground):
            ap.text(mav.MAV_SEVERITY_NOTICE, f"{fence_names(new)} breached")
        action = int(ap.params.get("FENCE_ACTION", 1))
        if action != 0:
            ap.failsafe.fence_action(action, self.breach_distance > FORCE_LAND_M)

    def sys_status_bits(self) -> tuple[bool, bool, bool]:
        """(present, enabled, healthy) for SYS_STATUS MAV_SYS_STATUS_GEOFENCE."""
        present = bool(self.present())
        enabled = present and self.enabled() and int(self.ap.params.get("FENCE_ACTION", 1)) != 0
        return present, enabled, self.breaches == 0
