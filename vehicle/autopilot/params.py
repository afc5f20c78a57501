"""Parameter store: ArduPilot-named parameters with ranges, .parm files and persistence.

Each vehicle owns one ParamStore. Its table is the cores' table (vehicle/params_core.py,
physics/control/estimation tuning) plus the autopilot's own parameters below. Values come,
lowest priority first, from: the table default, the world's `--params FILE` (ArduPilot
.parm "NAME VALUE" lines; like SITL's --defaults), and the vehicle's saved file in the
state dir (like SITL's eeprom.bin: every PARAM_SET is written there at once and loaded on
restart). Indexes are stable: names are sorted alphabetically.
"""
from __future__ import annotations

import math
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.param_def import ParamDef
# what ground stations read by default; the definitions below win over them
from vehicle.autopilot.params_ardupilot import COPTER_EXTRA, META, ROVER_EXTRA, TYPES, UNITS


def _d(name, default, lo, hi, integer=False, doc=""):
    units, ptype = META.get(name, ("", None))
    return ParamDef(name, float(default), float(lo), float(hi), integer, doc, UNITS.get(name, units),
                    TYPES.get(name, ptype))


_STREAMS = [
    # ArduPilot stream groups (Hz); defaults chosen like a SITL with MAVProxy attached.
    _d("SR0_RAW_SENS", 0, 0, 50, True, "RAW_IMU, SCALED_IMU2, SCALED_IMU3, SCALED_PRESSURE, SCALED_PRESSURE2 (Hz)"),
    _d("SR0_EXT_STAT", 2, 0, 50, True, "SYS_STATUS, POWER_STATUS, MEMINFO, MISSION_CURRENT, GPS_RAW_INT, "
       "NAV_CONTROLLER_OUTPUT, FENCE_STATUS, POSITION_TARGET_GLOBAL_INT, POSITION_TARGET_LOCAL_NED, "
       "EXTENDED_SYS_STATE (Hz)"),
    _d("SR0_RC_CHAN", 0, 0, 50, True, "SERVO_OUTPUT_RAW, RC_CHANNELS (Hz)"),
    _d("SR0_RAW_CTRL", 0, 0, 50, True, "RC_CHANNELS_SCALED (Rover) (Hz)"),
    _d("SR0_POSITION", 10, 0, 50, True, "GLOBAL_POSITION_INT, LOCAL_POSITION_NED (Hz)"),
    _d("SR0_EXTRA1", 10, 0, 50, True, "ATTITUDE, SIMSTATE, SIM_STATE, AHRS2, PID_TUNING, ATTITUDE_QUATERNION (Hz)"),
    _d("SR0_EXTRA2", 4, 0, 50, True, "VFR_HUD (Hz)"),
    _d("SR0_EXTRA3", 1, 0, 50, True, "AHRS, WIND, SYSTEM_TIME, BATTERY_STATUS, EKF_STATUS_REPORT, VIBRATION, "
       "HOME_POSITION (Hz)"),
    _d("SR0_PARAMS", 0, 0, 50, True, "parameter stream rate (unused)"),
    _d("SR0_ADSB", 0, 0, 50, True, "ADSB stream rate (unused)"),
    _d("GCS_PID_MASK", 0, 0, 127, True, "PID_TUNING axes sent in SR0_EXTRA1: Copter 1 roll, 2 pitch, 4 yaw, "
       "8 accel z; Rover 1 steering rate, 2 speed"),
]

_COMMON = [
    _d("SYSID_THISMAV", 1, 1, 255, True, "MAVLink system id of this vehicle"),
    _d("SYSID_MYGCS", 255, 1, 255, True, "ground station system id (informational)"),
    _d("FS_GCS_TIMEOUT", 5, 2, 120, False, "GCS failsafe timeout (s, sim time)"),
    _d("ARMING_CHECK", 1, 0, 1, True, "1 run pre-arm checks, 0 skip them"),
    _d("BATT_CAPACITY", 3300, 0, 100000, True, "battery capacity (mAh)"),
    _d("GUID_TIMEOUT", 3, 0.1, 5, False, "GUIDED velocity/acceleration target timeout (s)"),
    _d("MIS_RESTART", 0, 0, 1, True, "entering AUTO: 0 resume the mission where it stopped, 1 restart it"),
    _d("FENCE_ENABLE", 0, 0, 1, True, "geofence: 0 disabled, 1 enabled"),
    _d("FENCE_RADIUS", 300, 30, 10000, False, "circle fence radius around home (m)"),
    _d("FENCE_MARGIN", 2, 1, 10, False, "distance to keep from the fence (m; pre-arm check only)"),
]

_SRTL = [
    _d("SRTL_ACCURACY", 2, 0, 10, False, "SmartRTL: minimum distance between path points (m)"),
    _d("SRTL_POINTS", 300, 0, 500, True, "SmartRTL: maximum points on the path, 0 disables (reboot)"),
]

_FENCE_ALT = [
    _d("FENCE_ALT_MAX", 100, 10, 1000, False, "maximum altitude above home (m)"),
    _d("FENCE_ALT_MIN", -10, -100, 100, False, "minimum altitude above home (m)"),
]

# battery and wind: ArduPilot's AP_BattMonitor and SITL parameters, one block
# (vehicle/autopilot/battery.py and vehicle/physics/wind.py do what they say)
def _battery_wind(kind: str) -> list[ParamDef]:
    acts = ("0 none, 1 Land, 2 RTL, 3 SmartRTL or RTL, 4 SmartRTL or Land, 5 Terminate, "
            "6 Auto DO_LAND_START or RTL, 7 Brake or Land") if kind == "copter" else \
        "0 none, 1 RTL, 2 Hold, 3 SmartRTL or RTL, 4 SmartRTL or Hold, 5 Terminate"
    top = 7 if kind == "copter" else 5
    return [
        _d("BATT_MONITOR", 4, 0, 33, True, "battery monitor: 0 none, 3 analog voltage only, 4 analog voltage and current (simulated)"),
        _d("BATT_LOW_VOLT", 10.5, 0, 100, False, "low battery voltage (V), 0 = off; must last BATT_LOW_TIMER"),
        _d("BATT_CRT_VOLT", 0, 0, 100, False, "critical battery voltage (V), 0 = off; must last BATT_LOW_TIMER"),
        _d("BATT_LOW_MAH", 0, 0, 100000, True, "low battery: remaining capacity below this (mAh), 0 = off"),
        _d("BATT_CRT_MAH", 0, 0, 100000, True, "critical battery: remaining capacity below this (mAh), 0 = off"),
        _d("BATT_LOW_TIMER", 10, 0, 120, True, "seconds a low/critical voltage must last before the failsafe, 0 = no voltage failsafe"),
        _d("BATT_FS_VOLTSRC", 0, 0, 1, True, "failsafe voltage: 0 raw (under load), 1 sag-compensated (resting estimate)"),
        _d("BATT_FS_LOW_ACT", 0, 0, top, True, f"low battery failsafe action: {acts}"),
        _d("BATT_FS_CRT_ACT", 0, 0, top, True, f"critical battery failsafe action: {acts}"),
        _d("SIM_BATT_VOLTAGE", 12.6, 0, 100, False, "simulated battery: full-charge voltage (V); cells = round(V / 4.2)"),
        _d("SIM_BATT_CAP_AH", 0, 0, 1000, False, "simulated battery: true capacity (Ah), 0 = BATT_CAPACITY"),
        _d("SIM_WIND_SPD", 0, 0, 40, False, "simulated wind speed (m/s); one air mass per world"),
        _d("SIM_WIND_DIR", 180, 0, 360, False, "direction the simulated wind comes from (deg, 0 north, 90 east)"),
        _d("SIM_WIND_TURB", 0, 0, 10, False, "simulated turbulence, standard deviation (m/s)"),
        _d("SIM_WIND_DIR_Z", 0, -90, 90, False, "vertical wind angle (deg, positive = rising air)"),
        _d("SIM_WIND_T", 0, 0, 2, True, "wind profile with height: 0 square law below SIM_WIND_T_ALT, 1 none, 2 linear"),
        _d("SIM_WIND_T_ALT", 60, 0, 1000, False, "height of full wind strength (m)"),
        _d("SIM_WIND_T_COEF", 0.01, -1, 1, False, "linear profile: (m/s) per m above SIM_WIND_T_ALT"),
    ]


COPTER_TABLE = _STREAMS + _COMMON + _battery_wind("copter") + [
    _d("FS_GCS_ENABLE", 0, 0, 6, True,
       "GCS failsafe: 0 off, 1 RTL, 2 RTL, 3 SmartRTL->RTL, 4 SmartRTL->LAND, 5 LAND, 6 RTL"),
    _d("RTL_ALT", 1500, 30, 300000, True, "RTL return altitude (cm above home)"),
    _d("RTL_SPEED", 0, 0, 2000, True, "RTL horizontal speed (cm/s), 0 = WPNAV_SPEED"),
    _d("LAND_SPEED", 50, 30, 200, True, "final landing descent speed (cm/s)"),
    _d("LAND_SPEED_HIGH", 0, 0, 2500, True, "descent speed above 10 m (cm/s), 0 = WPNAV_SPEED_DN"),
    _d("DISARM_DELAY", 10, 0, 127, True, "auto-disarm after this long landed (s), 0 = never"),
    _d("WPNAV_SPEED_DN", 150, 10, 500, False, "maximum descent speed (cm/s)"),
    _d("WPNAV_SPEED", 500, 20, 2000, False, "horizontal speed (cm/s)"),
    _d("WPNAV_RADIUS", 200, 5, 1000, False, "AUTO waypoint radius (cm): a waypoint is reached inside it"),
    _d("WP_YAW_BEHAVIOR", 2, 0, 3, True,
       "AUTO yaw: 0 never change, 1 face next waypoint, 2 face next waypoint except RTL, 3 face along GPS course"),
    _d("AUTO_OPTIONS", 0, 0, 255, True,
       "bitmask: 0 AllowArming, 1 AllowTakeOffWithoutRaisingThrottle, 2 IgnorePilotYaw, 7 AllowWeatherVaning"),
    _d("CIRCLE_RATE", 20, -90, 90, False, "NAV_LOITER_TURNS turn rate (deg/s)"),
    _d("FENCE_TYPE", 7, 0, 15, True, "fence types bitmask: 0 max altitude, 1 circle, 2 polygons/circles, 3 min altitude"),
    _d("FENCE_ACTION", 1, 0, 5, True,
       "breach: 0 report only, 1 RTL or Land, 2 always Land, 3 SmartRTL or RTL or Land, 4 Brake or Land, 5 SmartRTL or Land"),
    _d("RALLY_LIMIT_KM", 0.3, 0, 100, False, "rally points further than this from home are ignored (km), 0 = no limit"),
    _d("RALLY_INCL_HOME", 1, 0, 1, True, "1: RTL also considers home and goes there when it is nearer"),
    _d("PHLD_BRAKE_RATE", 8, 4, 12, True, "POSHOLD braking rate: lean angle change (deg/s)"),
    _d("PHLD_BRAKE_ANGLE", 3000, 2000, 4500, True, "POSHOLD braking angle max (cdeg)"),
] + _FENCE_ALT + _SRTL

ROVER_TABLE = _STREAMS + _COMMON + _battery_wind("rover") + [
    _d("FS_GCS_ENABLE", 0, 0, 2, True, "GCS failsafe: 0 off, 1 on (action FS_ACTION), 2 on, continue in AUTO"),
    _d("FS_ACTION", 2, 0, 4, True, "failsafe action: 0 none, 1 RTL, 2 Hold, 3 SmartRTL->RTL, 4 SmartRTL->Hold"),
    _d("WP_RADIUS", 2, 0.1, 100, False, "waypoint radius (m): RTL done inside it"),
    _d("WP_SPEED", 0, 0, 100, False, "waypoint speed (m/s), 0 = CRUISE_SPEED"),
    _d("CRUISE_SPEED", 8, 0, 100, False, "cruise speed (m/s)"),
    _d("MIS_DONE_BEHAVE", 0, 0, 3, True, "mission end: 0 Hold, 1 Loiter, 2 Acro, 3 Manual (towerlink: 0 only)"),
    _d("FENCE_TYPE", 6, 0, 6, True, "fence types bitmask: 1 circle, 2 polygons/circles"),
    _d("FENCE_ACTION", 1, 0, 4, True,
       "breach: 0 report only, 1 RTL or Hold, 2 Hold, 3 SmartRTL or RTL or Hold, 4 SmartRTL or Hold"),
    _d("RALLY_LIMIT_KM", 0.5, 0, 100, False, "rally points further than this from home are ignored (km), 0 = no limit"),
    _d("RALLY_INCL_HOME", 1, 0, 1, True, "1: RTL also considers home and goes there when it is nearer"),
    _d("LOIT_RADIUS", 2, 0.5, 100, False, "LOITER: distance from the loiter point before driving back (m)"),
] + _SRTL

COPTER_TABLE = COPTER_TABLE + COPTER_EXTRA
ROVER_TABLE = ROVER_TABLE + ROVER_EXTRA


# FOLLOW mode (vehicle/autopilot/follow_mode.py), AP_Follow's names, defaults and ranges
_FOLLOW = [
    _d("FOLL_ENABLE", 0, 0, 1, True, "follow: 0 disabled, 1 enabled (FOLLOW mode needs it)"),
    _d("FOLL_SYSID", 0, 0, 255, True, "follow target's MAVLink system id, 0 = the first one heard"),
    _d("FOLL_DIST_MAX", 100, 1, 1000, False, "follow distance maximum (m): further, the target is invalid"),
    _d("FOLL_OFS_TYPE", 0, 0, 1, True, "follow offset type: 0 north-east-down, 1 relative to the lead's heading"),
    _d("FOLL_OFS_X", 0, -100, 100, False, "follow offset north / forward (m)"),
    _d("FOLL_OFS_Y", 0, -100, 100, False, "follow offset east / right (m)"),
    _d("FOLL_OFS_Z", 0, -100, 100, False, "follow offset down (m)"),
    _d("FOLL_POS_P", 0.1, 0.01, 1.0, False, "follow position error P gain (1/s)"),
]
_FOLLOW_COPTER = [
    _d("FOLL_YAW_BEHAVE", 1, 0, 3, True,
       "follow yaw: 0 none, 1 face the lead vehicle, 2 same as the lead, 3 direction of flight"),
    _d("FOLL_ALT_TYPE", 1, 0, 1, True, "follow altitude type: 0 absolute, 1 relative (towerlink: relative)"),
]


def _add_missing(table: list[ParamDef], extra: list[ParamDef]) -> None:
    have = {d.name for d in table}
    table += [d for d in extra if d.name not in have]


_add_missing(COPTER_TABLE, _FOLLOW + _FOLLOW_COPTER)
_add_missing(ROVER_TABLE, _FOLLOW)


def core_table(kind: str) -> list[ParamDef]:
    """The cores' parameters (vehicle/params_core.py) as ParamDefs; [] if not available."""
    try:
        from vehicle import params_core  # owned by the physics/control engineer
    except ImportError:
        return []
    return list(_core_defs(params_core, kind))


def _core_defs(params_core, kind: str) -> Iterable[ParamDef]:
    fn = getattr(params_core, "param_table", None)
    table = fn(kind) if callable(fn) else getattr(params_core, f"{kind.upper()}_PARAMS", {})
    items = table.items() if isinstance(table, Mapping) else ((getattr(p, "name"), p) for p in table)
    for name, p in items:
        if isinstance(p, Mapping):
            default, lo, hi = p["default"], p.get("min", -math.inf), p.get("max", math.inf)
            integer, doc = bool(p.get("integer", False)), p.get("doc", "")
        elif isinstance(p, (tuple, list)):
            default, lo, hi = p[0], p[1], p[2]
            integer, doc = (bool(p[3]) if len(p) > 3 else False), (p[4] if len(p) > 4 else "")
        else:
            default = getattr(p, "default")
            lo, hi = getattr(p, "min", getattr(p, "lo", -math.inf)), getattr(p, "max", getattr(p, "hi", math.inf))
            integer = bool(getattr(p, "integer", False))
            doc = getattr(p, "doc", getattr(p, "description", ""))
        units = str(getattr(p, "units", "") or "")
        ptype = TYPES.get(str(name))
        integer = integer or (ptype is not None and ptype != mav.MAV_PARAM_TYPE_REAL32)
        yield ParamDef(str(name), float(default), float(lo), float(hi), integer, str(doc), units, ptype)


class ParamFileError(ValueError):
    """A parameter file that cannot be read at all (str() says why)."""


def _warn(msg: str) -> None:
    print(f"towerlink sitl: {msg}", file=sys.stderr, flush=True)


def read_parm_file(path: str, warn: Callable[[str], None] = _warn) -> dict[str, float]:
    """ArduPilot .parm / MAVProxy param file: "NAME VALUE" (comma or spaces), # comments.

    A bad line (not ASCII, no NAME VALUE pair, a value that is no number) is skipped with a
    warning naming the file and line. Raises OSError when the file cannot be opened, and
    ParamFileError when it holds bad lines and not a single good one (binary garbage)."""
    out: dict[str, float] = {}
    bad = 0
    with open(path, "rb") as f:
        data = f.read()
    for n, raw in enumerate(data.splitlines(), 1):
        why = None
        try:
            text = raw.decode("ascii")
        except UnicodeDecodeError:
            text, why = "", "not ASCII text"
        line = text.split("#", 1)[0].strip()
        if why is None and not line:
            continue
        parts = re.split(r"[\s,]+", line)
        if why is None and (len(parts) < 2 or not re.fullmatch(r"[A-Za-z0-9_]{1,16}", parts[0])):
            why = "expected NAME VALUE"
        if why is None:
            try:
                out[parts[0].upper()] = float(parts[1])
            except ValueError:
                why = f"value {parts[1][:20]!r} is not a number"
        if why is not None:
            bad += 1
            warn(f"{path}:{n}: skipped a bad line ({why})")
    if bad and not out:
        raise ParamFileError(f"{path}: no readable parameter line ({bad} bad)")
    return out


def file_warnings(values: Mapping[str, float], defs: Mapping[str, ParamDef], kind: str, path: str) -> list[str]:
    """What `towerlink sitl --params FILE` says about a file for one vehicle kind: names this
    vehicle does not have (a real ArduPilot .parm holds hundreds; they are skipped, not fatal)
    and values outside a parameter's range (the default is kept)."""
    out = []
    unknown = sorted(n for n in values if n not in defs)
    if unknown:
        shown = ", ".join(unknown[:8]) + (", ..." if len(unknown) > 8 else "")
        out.append(f"{path}: {len(unknown)} parameter(s) unknown to the {kind}, skipped: {shown}")
    for n in sorted(values):
        d = defs.get(n)
        if d is not None:
            v = values[n]
            if not math.isfinite(v) or not d.lo <= (round(v) if d.integer else v) <= d.hi:
                out.append(f"{path}: {n} {v:g} out of range {d.lo:g}..{d.hi:g} for the {kind}, default kept")
    return out


def write_parm_file(path: str, values: Mapping[str, float]) -> None:
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w") as f:
        for name in sorted(values):
            v = values[name]
            f.write(f"{name} {int(v) if float(v).is_integer() else repr(float(v))}\n")
    os.replace(tmp, path)


class ParamStore:
    """Named values with ranges; set() refuses NaN/inf/out-of-range and persists on success."""

    def __init__(self, table: Iterable[ParamDef], defaults: Mapping[str, float] | None = None,
                 save_path: str | None = None, warn: Callable[[str], None] = _warn,
                 deferred: bool = False) -> None:
        """deferred: a PARAM_SET is written by the next flush() (the link calls it once a
        tick and at close), not at once: a datagram of 1871 PARAM_SETs cost 2.3 s of file
        writes and stalled the world; ArduPilot also saves parameters from a queue, not in the
        message handler."""
        self.deferred = deferred
        self.defs: dict[str, ParamDef] = {}
        for d in table:
            self.defs.setdefault(d.name, d)         # first table wins (cores before autopilot)
        self.names: list[str] = sorted(self.defs)
        self.index = {n: i for i, n in enumerate(self.names)}
        self.defaults = dict(defaults or {})
        self.save_path = save_path
        self.warn = warn
        self.saved: dict[str, float] = {}           # what persists (the file, or memory without one)
        self.values: dict[str, float] = {}
        self.saved = self._load_saved()
        self._apply()

    def _apply(self) -> None:
        self.changes += 1
        self.values = {n: d.default for n, d in self.defs.items()}
        for source in self.defaults, self.saved:
            for name, value in source.items():
                if name in self.defs and self.check(name, value) is None:
                    self.values[name] = self._coerce(name, value)

    def reload(self) -> None:
        """Re-read the saved parameters (a reboot): defaults, then what was saved."""
        self.flush()
        if self.save_path:
            self.saved = self._load_saved()
        self._apply()

    def _load_saved(self) -> dict[str, float]:
        """The saved file's known names; a file that cannot be read at all is set aside as
        FILE.bad (like a damaged eeprom.bin) and the vehicle starts on its defaults."""
        path = self.save_path
        if not path or not os.path.exists(path):
            return {}
        try:
            values = read_parm_file(path, self.warn)
        except (OSError, ParamFileError) as e:
            aside = path + ".bad"
            try:
                os.replace(path, aside)
                self.warn(f"saved parameters unreadable ({e}); moved to {aside}, starting on defaults")
            except OSError as e2:
                self.warn(f"saved parameters unreadable ({e}) and not moved aside ({e2}); starting on defaults")
            return {}
        return {n: v for n, v in values.items() if n in self.defs}

    def __len__(self) -> int:
        return len(self.names)

    def __contains__(self, name: str) -> bool:
        return name in self.defs

    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def get(self, name: str, default: float | None = None) -> float | None:
        return self.values.get(name, default)

    def _coerce(self, name: str, value: float) -> float:
        return float(round(value)) if self.defs[name].integer else float(value)

    def check(self, name: str, value: float) -> str | None:
        """None if `value` is acceptable for `name`, else the reason."""
        d = self.defs.get(name)
        if d is None:
            return f"unknown parameter {name}"
        if not math.isfinite(value):
            return f"{name}: value not finite"
        v = self._coerce(name, value)
        if v < d.lo or v > d.hi:
            return f"{name} {value:g} out of range {d.lo:g}..{d.hi:g}"
        return None

    def set(self, name: str, value: float, save: bool = True) -> str | None:
        """Set and persist; returns None on success, else the reason it was refused."""
        why = self.check(name, value)
        if why is not None:
            return why
        self.values[name] = self._coerce(name, value)
        self.changes += 1
        if save:
            self.saved[name] = self.values[name]
            self.dirty = True
            if not self.deferred:
                self.flush()
        return None

    # the link sets deferred: PARAM_SETs are written once a tick (flush), not once each (a
    # datagram of 1871 PARAM_SETs cost 2.3 s of file writes and stalled the world); ArduPilot
    # also saves parameters from a queue, not in the message handler
    deferred = False
    dirty = False
    # counts the changes of any value (set, reload): what derives from the parameters can tell
    # it is still current without reading them again (rc_input.py's stick scaling)
    changes = 0

    def flush(self) -> None:
        """Write the saved parameters if a set() changed them since the last write."""
        if self.dirty and self.save_path:
            write_parm_file(self.save_path, self.saved)
        self.dirty = False
