"""Defaults for the parameters the vehicle cores read (ArduPilot names and units).

The autopilot's parameter store imports ``COPTER_PARAMS`` / ``ROVER_PARAMS`` (and
``defaults(kind)``) so that PARAM_* over MAVLink shows and validates the same table the
cores use. Each entry: name -> ParamDef(default, lo, hi, units, doc).

Units are ArduPilot's (cm/s, cm/s/s, centidegrees, deg/s ...); the cores convert to SI.
Where towerlink's meaning differs from ArduPilot's (the rate PIDs act on this airframe's
normalised torque, which is scaled like ArduPilot's so its defaults work) the doc says so.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass


@dataclass(frozen=True)
class ParamDef:
    default: float
    lo: float
    hi: float
    units: str
    doc: str


def _p(default, lo, hi, units, doc):
    return ParamDef(float(default), float(lo), float(hi), units, doc)


COPTER_PARAMS: dict[str, ParamDef] = {
    # waypoint / guided kinematic limits (AC_WPNav, AC_PosControl)
    "WPNAV_SPEED": _p(500, 20, 2000, "cm/s", "horizontal speed limit for position moves"),
    "WPNAV_SPEED_UP": _p(250, 10, 1000, "cm/s", "climb speed limit"),
    "WPNAV_SPEED_DN": _p(150, 10, 500, "cm/s", "descent speed limit"),
    "WPNAV_ACCEL": _p(250, 50, 500, "cm/s/s", "horizontal acceleration limit"),
    "WPNAV_ACCEL_Z": _p(100, 50, 500, "cm/s/s", "vertical acceleration limit"),
    "PSC_JERK_XY": _p(5, 1, 20, "m/s/s/s", "horizontal jerk limit of the shaped target"),
    "PSC_JERK_Z": _p(5, 5, 50, "m/s/s/s", "vertical jerk limit of the shaped target"),
    "ANGLE_MAX": _p(3000, 1000, 8000, "cdeg", "maximum lean angle"),
    "LAND_SPEED": _p(50, 30, 200, "cm/s", "final descent speed when landing"),
    # position controller (AC_PosControl)
    "PSC_POSXY_P": _p(1.0, 0.5, 2.0, "1/s", "horizontal position error -> velocity"),
    "PSC_VELXY_P": _p(2.0, 0.1, 6.0, "1/s", "horizontal velocity error -> acceleration"),
    "PSC_VELXY_I": _p(1.0, 0.0, 3.0, "1/s/s", "horizontal velocity integrator"),
    "PSC_VELXY_D": _p(0.5, 0.0, 1.0, "", "horizontal velocity derivative"),
    "PSC_VELXY_IMAX": _p(1000, 0, 4500, "cm/s/s", "horizontal velocity integrator limit"),
    "PSC_POSZ_P": _p(1.0, 0.5, 3.0, "1/s", "altitude error -> climb rate"),
    "PSC_VELZ_P": _p(5.0, 1.0, 8.0, "1/s", "climb-rate error -> vertical acceleration"),
    "PSC_VELZ_I": _p(2.0, 0.0, 10.0, "1/s/s", "climb-rate integrator (towerlink; ArduPilot has PSC_ACCZ_I)"),
    "PSC_VELZ_IMAX": _p(500, 0, 1000, "cm/s/s", "climb-rate integrator limit"),
    # attitude controller (AC_AttitudeControl): angle P -> rate PID on normalised torque
    "ATC_ANG_RLL_P": _p(4.5, 3.0, 12.0, "1/s", "roll angle error -> roll rate"),
    "ATC_ANG_PIT_P": _p(4.5, 3.0, 12.0, "1/s", "pitch angle error -> pitch rate"),
    "ATC_ANG_YAW_P": _p(4.5, 3.0, 12.0, "1/s", "yaw angle error -> yaw rate"),
    "ATC_RAT_RLL_P": _p(0.135, 0.01, 0.5, "", "roll rate P (normalised torque per rad/s)"),
    "ATC_RAT_RLL_I": _p(0.135, 0.01, 2.0, "", "roll rate I"),
    "ATC_RAT_RLL_D": _p(0.0036, 0.0, 0.05, "", "roll rate D"),
    "ATC_RAT_RLL_IMAX": _p(0.5, 0, 1, "", "roll rate integrator limit"),
    "ATC_RAT_PIT_P": _p(0.135, 0.01, 0.5, "", "pitch rate P"),
    "ATC_RAT_PIT_I": _p(0.135, 0.01, 2.0, "", "pitch rate I"),
    "ATC_RAT_PIT_D": _p(0.0036, 0.0, 0.05, "", "pitch rate D"),
    "ATC_RAT_PIT_IMAX": _p(0.5, 0, 1, "", "pitch rate integrator limit"),
    "ATC_RAT_YAW_P": _p(0.18, 0.1, 2.5, "", "yaw rate P"),
    "ATC_RAT_YAW_I": _p(0.018, 0.0, 1.0, "", "yaw rate I"),
    "ATC_RAT_YAW_D": _p(0.0, 0.0, 0.02, "", "yaw rate D"),
    "ATC_RAT_YAW_IMAX": _p(0.5, 0, 1, "", "yaw rate integrator limit"),
    "ATC_RATE_Y_MAX": _p(90, 0, 1080, "deg/s", "yaw rate limit (also the slew of yaw targets); 0 = 90"),
    "ATC_RATE_RP_MAX": _p(360, 0, 1080, "deg/s", "roll/pitch rate limit (towerlink: one for both)"),
    # motors
    "MOT_THST_HOVER": _p(0.45, 0.125, 0.6875, "", "hover thrust fraction the controller assumes"),
    "MOT_SPIN_ARM": _p(0.1, 0.0, 0.2, "", "rotor speed fraction when armed and idle on the ground"),
    "MOT_SPIN_MIN": _p(0.15, 0.0, 0.3, "", "minimum rotor speed fraction in flight"),
    # land detector
    "LAND_DETECT_TIME": _p(1.0, 0.2, 5.0, "s", "towerlink: on-ground conditions must hold this long"),
}

ROVER_PARAMS: dict[str, ParamDef] = {
    "CRUISE_SPEED": _p(8.0, 0, 100, "m/s", "target speed in auto/guided (skid-steer rover)"),
    "WP_SPEED": _p(0.0, 0, 100, "m/s", "waypoint speed; 0 = use CRUISE_SPEED"),
    # The sim rover is an agile small skid-steer UGV (about 0.5 g, a 4.2 rad/s spin like a
    # Clearpath Jackal's) so that it can follow a 5 m/s multicopter through stop-and-turn
    # corners within 1 m RMS; ArduPilot's own defaults suit larger, slower rovers.
    "ATC_ACCEL_MAX": _p(5.0, 0, 10, "m/s/s", "speed-up acceleration limit (5 = the model's traction limit)"),
    "ATC_DECEL_MAX": _p(0.0, 0, 10, "m/s/s", "slow-down limit; 0 = ATC_ACCEL_MAX"),
    "ATC_STR_RAT_MAX": _p(240, 0, 1000, "deg/s", "turn-rate limit"),
    "ATC_STR_ANG_P": _p(2.5, 1, 10, "1/s", "heading error -> turn rate"),
    "ATC_SPEED_P": _p(1.0, 0, 2, "1/s", "towerlink: position error -> speed correction (follow)"),
    "PIVOT_TURN_ANGLE": _p(90, 0, 360, "deg", "heading error above which the rover turns in place"),
    "WP_RADIUS": _p(0.3, 0.1, 100, "m", "towerlink: stop within this distance of a position goal"),
    "SIM_RVR_MAX_SPD": _p(12.0, 1, 30, "m/s", "towerlink sim: rover top speed"),
}


def defaults(kind: str = "copter") -> dict[str, float]:
    """Default values by name for ``kind`` = 'copter' or 'rover'."""
    table = COPTER_PARAMS if kind == "copter" else ROVER_PARAMS
    return {k: d.default for k, d in table.items()}


def validate(kind: str, name: str, value: float) -> bool:
    """True when ``name`` belongs to ``kind``'s table and ``value`` is in range."""
    table = COPTER_PARAMS if kind == "copter" else ROVER_PARAMS
    d = table.get(name)
    return d is not None and d.lo <= float(value) <= d.hi


def merged(kind: str, params: Mapping[str, float] | None) -> dict[str, float]:
    """Defaults overlaid with the known names from ``params`` (unknown names ignored)."""
    out = defaults(kind)
    if params:
        for k, v in params.items():
            if k in out:
                out[k] = float(v)
    return out
