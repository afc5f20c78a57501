"""The ArduPilot parameters ground stations read or show by default, with ArduPilot's types
(AP_Int8/16/32, AP_Float -> MAV_PARAM_TYPE_*), ranges and units (the @Range / @Units of the
ArduCopter 4.5 / Rover 4.5 parameter tables).

QGroundControl's setup pages (airframe, radio, flight modes, safety, power), MAVProxy and MAVSDK
look these up; a missing name shows as an error or an empty page. Each doc says what towerlink
does with the parameter: most are honoured where the simulation has the concept (listed in
USED_*), the rest are stored, range-checked and persisted as ArduPilot would, and the doc starts
"not simulated" (RC auxiliary functions, no compass calibration...) or names the issue-10 part
that will use them (FOLL_*: FOLLOW; SIM_WIND_*: wind; BATT_LOW_*/BATT_FS_*: battery failsafe).

Tables: list of ParamDef (vehicle/autopilot/param_def.py, tables in params.py); the first table that names a
parameter wins, so the autopilot's own definitions (params.py) and the cores' come first.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.param_def import ParamDef
from vehicle.sim_faults import PARAM_ROWS as SIM_FAULT_ROWS

I8, I16, I32, F = (mav.MAV_PARAM_TYPE_INT8, mav.MAV_PARAM_TYPE_INT16, mav.MAV_PARAM_TYPE_INT32,
                   mav.MAV_PARAM_TYPE_REAL32)
NS = "not simulated: stored only"


def _defs(rows):
    out = []
    for name, default, lo, hi, ptype, units, doc in rows:
        out.append(ParamDef(name, float(default), float(lo), float(hi), ptype != F, doc, units, ptype))
    return out


SIM = "simulated: the RC input from RC_CHANNELS_OVERRIDE / MANUAL_CONTROL (rc_input.py)"


def _rc(n: int, dz: int = 0):
    """RCn_* (RC_Channel.cpp); `dz` the vehicle's default dead zone (its default_dead_zones)."""
    return [(f"RC{n}_MIN", 1100, 800, 2200, I16, "PWM", f"RC{n} minimum pulse ({SIM})"),
            (f"RC{n}_MAX", 1900, 800, 2200, I16, "PWM", f"RC{n} maximum pulse ({SIM})"),
            (f"RC{n}_TRIM", 1500, 800, 2200, I16, "PWM", f"RC{n} trim (neutral) pulse ({SIM})"),
            (f"RC{n}_REVERSED", 0, 0, 1, I8, "", f"RC{n} reversed ({SIM})"),
            (f"RC{n}_DZ", dz, 0, 200, I16, "PWM", f"RC{n} dead zone about trim, or above the minimum for the throttle ({SIM})"),
            (f"RC{n}_OPTION", 0, 0, 400, I16, "", f"RC{n} auxiliary function ({NS})")]


_PILOT_SHARED = [
    ("RCMAP_ROLL", 1, 1, 16, I8, "", "roll (Rover: steering) input channel (reboot required)"),
    ("RCMAP_PITCH", 2, 1, 16, I8, "", "pitch input channel (reboot required)"),
    ("RCMAP_THROTTLE", 3, 1, 16, I8, "", "throttle input channel (reboot required)"),
    ("RCMAP_YAW", 4, 1, 16, I8, "", "yaw input channel (reboot required)"),
    ("RC_OVERRIDE_TIME", 3.0, -1, 120, F, "s", "RC override timeout: 0 disables overrides, -1 never times out"),
    ("RC_FS_TIMEOUT", 1.0, 0.1, 10, F, "s", "radio failsafe after this long without an RC frame (override or receiver)"),
    ("RC_OPTIONS", 32, 0, 2**31 - 1, I32, "", "RC input options: bit 0 ignore the receiver, bit 1 ignore MAVLink "
     "overrides (the others stored only)"),
    ("SIM_RC_FAIL", 0, 0, 2, I8, "", "simulated RC failure: 0 none, 1 no RC pulses, 2 all channels neutral except "
     "the throttle at 950 us (towerlink has no transmitter: 0 and 1 alike, 2 adds a receiver sending that)"),
]


_SHARED = [
    ("SYSID_ENFORCE", 0, 0, 1, I8, "", f"accept commands only from SYSID_MYGCS ({NS})"),
    ("BATT_MONITOR", 4, 0, 33, I8, "", "battery monitor type: 4 analog voltage and current (the simulated battery)"),
    ("BATT_ARM_VOLT", 0, 0, 100, F, "V", "pre-arm: minimum voltage"),
    ("BATT_ARM_MAH", 0, 0, 100000, I32, "mAh", "pre-arm: minimum remaining capacity"),
    ("BATT_LOW_VOLT", 10.5, 0, 100, F, "V", "low battery voltage (battery failsafe)"),
    ("BATT_CRT_VOLT", 0, 0, 100, F, "V", "critical battery voltage"),
    ("BATT_LOW_MAH", 0, 0, 100000, I32, "mAh", "low battery remaining capacity"),
    ("BATT_CRT_MAH", 0, 0, 100000, I32, "mAh", "critical battery remaining capacity"),
    ("BATT_LOW_TIMER", 10, 0, 120, I8, "s", "low voltage must last this long"),
    ("BATT_FS_VOLTSRC", 0, 0, 1, I8, "", "0 raw voltage, 1 sag-compensated"),
    ("BATT_SERIAL_NUM", -1, -1, 2**31 - 1, I32, "", f"battery serial number ({NS})"),
    ("BATT_VOLT_MULT", 10.1, 0, 100, F, "", f"voltage sensor multiplier ({NS})"),
    ("BATT_AMP_PERVLT", 17, 0, 1000, F, "A/V", f"current sensor scaling ({NS})"),
    ("BATT_AMP_OFFSET", 0, -1, 1, F, "V", f"current sensor offset ({NS})"),
    ("FENCE_AUTOENABLE", 0, 0, 3, I8, "", f"auto-enable the fence on takeoff ({NS})"),
    ("FENCE_RET_RALLY", 0, 0, 1, I8, "", f"fence breach returns to the nearest rally point ({NS})"),
    ("FENCE_RET_ALT", 0, 0, 32767, I16, "m", f"fence return altitude ({NS})"),
    ("FENCE_TOTAL", 0, 0, 127, I8, "", f"legacy polygon fence point count ({NS}: MAVLink fence items are used)"),
    ("FENCE_OPTIONS", 0, 0, 7, I16, "", f"fence options bitmask ({NS})"),
    ("FS_OPTIONS", 0, 0, 255, I32, "", f"failsafe options bitmask ({NS})"),
    ("ARMING_REQUIRE", 1, 0, 2, I8, "", f"arming required before motors spin ({NS}: always)"),
    ("ARMING_RUDDER", 2, 0, 2, I8, "", f"arm/disarm with rudder stick ({NS}: arming comes over MAVLink only)"),
    ("ARMING_ACCTHRESH", 0.75, 0.25, 3.0, F, "m/s/s", f"accelerometer consistency threshold ({NS})"),
    ("ARMING_MIS_ITEMS", 0, 0, 2**31 - 1, I32, "", f"required mission items bitmask ({NS})"),
    ("ARMING_OPTIONS", 0, 0, 7, I32, "", f"arming options bitmask ({NS})"),
    ("BRD_SAFETY_DEFLT", 0, 0, 1, I8, "", f"safety switch default state ({NS}: no safety switch)"),
    ("SERIAL0_BAUD", 115, 1, 2000, I32, "", f"USB console baud (kbaud code) ({NS})"),
    ("SERIAL0_PROTOCOL", 2, -1, 50, I8, "", f"USB console protocol: 2 MAVLink2 ({NS})"),
    ("LOG_BITMASK", 176126, 0, 2**31 - 1, I32, "", f"what the dataflash log records ({NS}: the onboard log records its fixed set)"),
    ("LOG_BACKEND_TYPE", 1, 0, 15, I8, "", "log backends bitmask: bit 0 the File backend (the onboard .BIN logs), 0 no logging"),
    ("LOG_DISARMED", 0, 0, 4, I8, "", "log while disarmed: 0 no (a log opens at arming), 1 and 2 yes, 3 yes but a log that never saw arming is discarded"),
    ("LOG_FILE_DSRMROT", 0, 0, 1, I8, "", "close the log at disarm (one log per arming) instead of at reboot"),
    ("AHRS_EKF_TYPE", 3, 0, 11, I8, "", "estimator: 3 EKF3 (towerlink's estimator plays that part)"),
    ("EK3_ENABLE", 1, 0, 1, I8, "", "EKF3 enabled (towerlink's estimator)"),
    ("EK2_ENABLE", 0, 0, 1, I8, "", f"EKF2 enabled ({NS})"),
    ("GPS_TYPE", 1, 0, 26, I8, "", "GPS 1 type: 1 auto (the simulated GPS)"),
    ("GPS_AUTO_SWITCH", 1, 0, 4, I8, "", f"GPS switching ({NS}: one GPS)"),
    ("COMPASS_ENABLE", 1, 0, 1, I8, "", "compass enabled (the estimator's heading)"),
    ("COMPASS_USE", 1, 0, 1, I8, "", "compass 1 used for yaw"),
    ("COMPASS_AUTODEC", 1, 0, 1, I8, "", f"declination from the position ({NS}: no magnetic field model)"),
    ("COMPASS_DEC", 0, -3.142, 3.142, F, "rad", f"magnetic declination ({NS})"),
    ("COMPASS_OFS_X", 5, -400, 400, F, "mGauss", f"compass offset X (SITL's calibrated value; {NS})"),
    ("COMPASS_OFS_Y", 13, -400, 400, F, "mGauss", f"compass offset Y ({NS})"),
    ("COMPASS_OFS_Z", -18, -400, 400, F, "mGauss", f"compass offset Z ({NS})"),
    ("INS_ACCOFFS_X", 0.001, -3.5, 3.5, F, "m/s/s", f"accelerometer offset X (calibrated; {NS})"),
    ("INS_ACCOFFS_Y", 0.001, -3.5, 3.5, F, "m/s/s", f"accelerometer offset Y ({NS})"),
    ("INS_ACCOFFS_Z", 0.001, -3.5, 3.5, F, "m/s/s", f"accelerometer offset Z ({NS})"),
    ("INS_ACCSCAL_X", 1.001, 0.8, 1.2, F, "", f"accelerometer scale X (calibrated; {NS})"),
    ("INS_ACCSCAL_Y", 1.001, 0.8, 1.2, F, "", f"accelerometer scale Y ({NS})"),
    ("INS_ACCSCAL_Z", 1.001, 0.8, 1.2, F, "", f"accelerometer scale Z ({NS})"),
    ("SIM_WIND_SPD", 0, 0, 40, F, "m/s", "simulated wind speed"),
    ("SIM_WIND_DIR", 180, 0, 360, F, "deg", "direction the simulated wind comes from"),
    ("SIM_WIND_TURB", 0, 0, 10, F, "m/s", "simulated wind turbulence"),
    ("SIM_WIND_T", 0, 0, 2, I8, "", "wind profile: 0 square, 1 none, 2 linear"),
    ("SIM_BATT_VOLTAGE", 12.6, 0, 100, F, "V", "simulated full battery voltage"),
    ("SIM_BATT_CAP_AH", 0, 0, 1000, F, "Ah", "simulated battery capacity, 0 = BATT_CAPACITY"),
    ("SIM_SPEEDUP", 1, 0, 100, F, "", "simulation speed-up (towerlink: set by `towerlink sitl --speedup`; stored only)"),
    *[(name, d, lo, hi, {"I8": I8, "I16": I16, "I32": I32, "F": F}[t], u, doc)
      for name, d, lo, hi, t, u, doc in SIM_FAULT_ROWS],       # SITL's injected faults (vehicle/sim_faults.py)
    ("FOLL_ENABLE", 0, 0, 1, I8, "", "FOLLOW mode enabled"),
    ("FOLL_SYSID", 0, 0, 255, I16, "", "lead vehicle's system id, 0 = the first seen"),
    ("FOLL_DIST_MAX", 100, 1, 1000, F, "m", "lead further than this is ignored"),
    ("FOLL_OFS_TYPE", 0, 0, 1, I8, "", "offset frame: 0 NED, 1 relative to the lead's heading"),
    ("FOLL_OFS_X", 0, -100, 100, F, "m", "offset from the lead, north / forward"),
    ("FOLL_OFS_Y", 0, -100, 100, F, "m", "offset from the lead, east / right"),
    ("FOLL_OFS_Z", 0, -100, 100, F, "m", "offset from the lead, down"),
    ("FOLL_YAW_BEHAVE", 1, 0, 3, I8, "", "yaw: 0 none, 1 face lead, 2 lead's heading, 3 direction of flight (FOLLOW part)"),
    ("FOLL_POS_P", 0.1, 0.01, 1.0, F, "", "follow position error P gain"),
    ("FOLL_ALT_TYPE", 1, 0, 1, I8, "", "lead altitude: 0 absolute, 1 relative"),
    ("FOLL_OPTIONS", 0, 0, 1, I16, "", "follow options bitmask"),
]
_SHARED += _PILOT_SHARED
# Copter's default dead zones: 20 on roll, pitch and yaw, 30 on the throttle (radio.cpp)
_COPTER_RC = [row for n in range(1, 9) for row in _rc(n, {1: 20, 2: 20, 3: 30, 4: 20}.get(n, 0))]
# Rover's: 30 on steering and throttle
_ROVER_RC = [row for n in range(1, 9) for row in _rc(n, {1: 30, 3: 30}.get(n, 0))]

_COPTER_ONLY = [
    ("FS_EKF_ACTION", 1, 1, 3, I8, "", "EKF failsafe action: 1 Land, 2 AltHold, 3 Land even in STABILIZE"),
    ("FS_EKF_THRESH", 0.8, 0, 1.0, F, "", "EKF failsafe variance threshold (0 disables the EKF check)"),
    ("FRAME_CLASS", 1, 0, 17, I8, "", "frame class: 1 Quad (towerlink simulates a quad only; reboot required)"),
    ("FRAME_TYPE", 1, 0, 19, I8, "", "frame type: 1 X (towerlink simulates X only; reboot required)"),
    ("FORMAT_VERSION", 120, 0, 32767, I16, "", "parameter format version (ArduCopter's)"),
    ("BATT_FS_LOW_ACT", 0, 0, 7, I8, "", "low battery action: 0 none, 1 Land, 2 RTL, 3 SmartRTL or RTL, 4 SmartRTL or Land, "
     "5 Terminate, 6 DO_LAND_START or RTL, 7 Brake or Land"),
    ("BATT_FS_CRT_ACT", 0, 0, 7, I8, "", "critical battery action, values as BATT_FS_LOW_ACT"),
    ("RTL_ALT_FINAL", 0, 0, 1000, I32, "cm", "RTL final altitude above home, 0 = land"),
    ("RTL_LOIT_TIME", 5000, 0, 60000, I32, "ms", "RTL loiter time above home before the final descent"),
    ("RTL_CLIMB_MIN", 0, 0, 3000, I16, "cm", f"RTL minimum climb ({NS})"),
    ("RTL_CONE_SLOPE", 3, 0.5, 10, F, "", f"RTL cone slope ({NS})"),
    ("RTL_OPTIONS", 0, 0, 7, I32, "", f"RTL options bitmask ({NS})"),
    ("RTL_ALT_TYPE", 0, 0, 1, I8, "", f"RTL altitude type ({NS}: relative)"),
    ("LAND_ALT_LOW", 1000, 100, 10000, I16, "cm", "altitude below which LAND descends at LAND_SPEED"),
    ("LAND_REPOSITION", 1, 0, 1, I8, "", "the sticks move the copter while it lands (LAND, RTL and AUTO landings)"),
    ("WPNAV_JERK", 1, 1, 20, F, "m/s/s/s", f"waypoint jerk limit ({NS}: PSC_JERK_XY shapes the path)"),
    ("WPNAV_RFND_USE", 1, 0, 1, I8, "", f"use the rangefinder for terrain following ({NS})"),
    ("WPNAV_TER_MARGIN", 10, 0.1, 100, F, "m", f"terrain following margin ({NS})"),
    ("WPNAV_ACCEL_C", 0, 0, 500, F, "cm/s/s", f"waypoint cornering acceleration ({NS})"),
    ("LOIT_SPEED", 1250, 20, 3500, F, "cm/s", "LOITER maximum pilot speed"),
    ("LOIT_ACC_MAX", 500, 100, 981, F, "cm/s/s", "LOITER acceleration to the pilot's velocity"),
    ("LOIT_BRK_ACCEL", 250, 25, 250, F, "cm/s/s", "LOITER deceleration when the sticks are eased or released"),
    ("LOIT_BRK_JERK", 500, 500, 5000, F, "cm/s/s/s", f"LOITER braking jerk ({NS})"),
    ("LOIT_BRK_DELAY", 1.0, 0, 2, F, "s", f"LOITER braking delay ({NS})"),
    ("LOIT_ANG_MAX", 0, 0, 45, F, "deg", f"LOITER maximum lean angle ({NS})"),
    ("PILOT_SPEED_UP", 250, 50, 500, I16, "cm/s", "pilot maximum climb rate (ALT_HOLD, LOITER, POSHOLD)"),
    ("PILOT_SPEED_DN", 0, 0, 500, I16, "cm/s", "pilot maximum descent rate, 0 = PILOT_SPEED_UP"),
    ("PILOT_ACCEL_Z", 250, 50, 500, I16, "cm/s/s", "pilot vertical acceleration (the climb rate's slew)"),
    ("THR_DZ", 100, 0, 300, I16, "PWM", "throttle dead band either side of mid stick (ALT_HOLD, LOITER, POSHOLD)"),
    ("PILOT_THR_FILT", 0, 0, 10, F, "Hz", f"throttle filter ({NS})"),
    ("PILOT_THR_BHV", 0, 0, 7, I16, "", f"throttle behaviour bitmask ({NS})"),
    ("PILOT_TKOFF_ALT", 0, 0, 1000, F, "cm", f"pilot takeoff altitude ({NS}: GUIDED NAV_TAKEOFF gives it)"),
    ("PILOT_Y_RATE", 202.5, 1, 360, F, "deg/s", "pilot yaw rate at full yaw stick"),
    ("PILOT_Y_EXPO", 0, -0.5, 1.0, F, "", "pilot yaw expo (a cubic blend of the stick)"),
    ("CIRCLE_RADIUS", 1000, 0, 200000, F, "cm", "CIRCLE radius (AUTO's NAV_LOITER_TURNS uses its own)"),
    ("GUID_OPTIONS", 0, 0, 255, I32, "", f"GUIDED options bitmask ({NS})"),
    ("FLTMODE_CH", 5, 0, 16, I8, "", f"flight mode channel ({NS}: modes change over MAVLink only)"),
    ("FLTMODE1", 0, 0, 28, I8, "", f"flight mode 1 ({NS})"),
    ("FLTMODE2", 0, 0, 28, I8, "", f"flight mode 2 ({NS})"),
    ("FLTMODE3", 0, 0, 28, I8, "", f"flight mode 3 ({NS})"),
    ("FLTMODE4", 0, 0, 28, I8, "", f"flight mode 4 ({NS})"),
    ("FLTMODE5", 0, 0, 28, I8, "", f"flight mode 5 ({NS})"),
    ("FLTMODE6", 0, 0, 28, I8, "", f"flight mode 6 ({NS})"),
    ("SIMPLE", 0, 0, 63, I8, "", f"simple mode bitmask ({NS})"),
    ("SUPER_SIMPLE", 0, 0, 63, I8, "", f"super simple mode bitmask ({NS})"),
    ("FS_THR_ENABLE", 1, 0, 7, I8, "", "radio failsafe: 0 off, 1 RTL, 2 RTL (continue in AUTO: FS_OPTIONS), 3 LAND, "
     "4 SmartRTL or RTL, 5 SmartRTL or LAND, 6 DO_LAND_START or RTL, 7 BRAKE or LAND"),
    ("FS_THR_VALUE", 975, 910, 1100, I16, "PWM", "throttle pulse below which the radio failsafe triggers"),
    ("FS_CRASH_CHECK", 1, 0, 1, I8, "", "crash check: 1 disarms a crashed copter (crash_check.py), 0 off"),
    ("FS_VIBE_ENABLE", 1, 0, 1, I8, "", f"vibration failsafe ({NS})"),
    ("MOT_PWM_MIN", 1000, 0, 2000, I16, "PWM", f"motor PWM minimum ({NS})"),
    ("MOT_PWM_MAX", 2000, 0, 2000, I16, "PWM", f"motor PWM maximum ({NS})"),
    ("MOT_BAT_VOLT_MAX", 0, 0, 53, F, "V", f"battery voltage compensation maximum ({NS})"),
    ("MOT_BAT_VOLT_MIN", 0, 0, 42, F, "V", f"battery voltage compensation minimum ({NS})"),
    ("TERRAIN_ENABLE", 0, 0, 1, I8, "", "terrain data (towerlink has none: 0)"),
    ("SCHED_LOOP_RATE", 400, 50, 400, I16, "Hz", f"main loop rate ({NS}: the world's autopilot rate)"),
]

_ROVER_ONLY = [
    ("FS_EKF_ACTION", 1, 0, 2, I8, "", "EKF failsafe action: 0 disabled, 1 Hold, 2 report only"),
    ("FS_EKF_THRESH", 0.8, 0, 1.0, F, "", "EKF failsafe variance threshold (0 disables the EKF check)"),
    ("FRAME_CLASS", 1, 0, 3, I8, "", "frame class: 1 Rover (towerlink simulates a skid-steer rover)"),
    ("FRAME_TYPE", 0, 0, 6, I8, "", "frame type: 0 Undefined (not omni)"),
    ("FORMAT_VERSION", 16, 0, 32767, I16, "", "parameter format version (Rover's)"),
    ("BATT_FS_LOW_ACT", 0, 0, 4, I8, "", "low battery action: 0 none, 1 RTL, 2 Hold, 3 SmartRTL or RTL, 4 SmartRTL or Hold "
     ""),
    ("BATT_FS_CRT_ACT", 0, 0, 4, I8, "", "critical battery action"),
    ("RTL_SPEED", 0, 0, 100, F, "m/s", f"RTL speed, 0 = WP_SPEED ({NS})"),
    ("RTL_OPTIONS", 0, 0, 1, I32, "", f"RTL options bitmask ({NS})"),
    ("WP_OVERSHOOT", 2, 0, 10, F, "m", f"waypoint overshoot ({NS})"),
    ("TURN_RADIUS", 0.9, 0, 10, F, "m", f"turn radius ({NS}: skid steering turns in place)"),
    ("CRUISE_THROTTLE", 50, 0, 100, I8, "%", f"throttle at CRUISE_SPEED ({NS})"),
    ("SPEED_MAX", 0, 0, 30, F, "m/s", "pilot top speed in ACRO and STEERING, 0 = the drive's (SIM_RVR_MAX_SPD)"),
    ("LOIT_TYPE", 0, 0, 2, I8, "", "LOITER type: 0 forward or reverse to the point"),
    ("ACRO_TURN_RATE", 180, 0, 360, F, "deg/s", "ACRO (and STEERING's) maximum turn rate"),
    ("MODE_CH", 8, 0, 16, I8, "", f"mode channel ({NS}: modes change over MAVLink only)"),
    ("MODE1", 0, 0, 16, I8, "", f"mode 1 ({NS})"),
    ("MODE2", 0, 0, 16, I8, "", f"mode 2 ({NS})"),
    ("MODE3", 0, 0, 16, I8, "", f"mode 3 ({NS})"),
    ("MODE4", 0, 0, 16, I8, "", f"mode 4 ({NS})"),
    ("MODE5", 0, 0, 16, I8, "", f"mode 5 ({NS})"),
    ("MODE6", 0, 0, 16, I8, "", f"mode 6 ({NS})"),
    ("FS_THR_ENABLE", 1, 0, 2, I8, "", "radio failsafe: 0 off, 1 on, 2 on (continue in AUTO)"),
    ("FS_THR_VALUE", 910, 0, 2200, I16, "PWM", "throttle pulse below which the radio failsafe triggers"),
    ("FS_TIMEOUT", 1.5, 1, 100, F, "s", "how long a radio failsafe condition lasts before FS_ACTION"),
    ("FS_CRASH_CHECK", 0, 0, 2, I8, "", f"crash check ({NS})"),
    ("MOT_PWM_TYPE", 0, 0, 8, I8, "", f"motor output type ({NS})"),
    ("TURN_MAX_G", 0.6, 0.1, 10, F, "gravities", "STEERING's lateral acceleration at full steering"),
]

COPTER_EXTRA = _defs(_COPTER_ONLY + _COPTER_RC + _SHARED)
ROVER_EXTRA = _defs(_ROVER_ONLY + _ROVER_RC + _SHARED)
# units and type by name from the rows above, for a parameter params.py defines itself (its
# definition wins, but ArduPilot's type and units stay): the first row naming it
META: dict[str, tuple[str, int]] = {}
for _row in _COPTER_ONLY + _COPTER_RC + _SHARED + _ROVER_ONLY:
    META.setdefault(_row[0], (_row[5], _row[4]))

# ArduPilot's type (and units) of the parameters params.py and the cores define, by name
TYPES = {
    "SYSID_THISMAV": I16, "SYSID_MYGCS": I16, "FS_GCS_ENABLE": I8, "ARMING_CHECK": I32,
    "BATT_CAPACITY": I32, "GUID_TIMEOUT": F, "MIS_RESTART": I8, "FENCE_ENABLE": I8, "FENCE_TYPE": I8,
    "FENCE_ACTION": I8, "RTL_ALT": I32, "RTL_SPEED": I16, "LAND_SPEED": I16, "LAND_SPEED_HIGH": I16,
    "DISARM_DELAY": I8, "WP_YAW_BEHAVIOR": I8, "AUTO_OPTIONS": I32, "RALLY_INCL_HOME": I8,
    "SRTL_POINTS": I16, "PHLD_BRAKE_RATE": I16, "PHLD_BRAKE_ANGLE": I16, "FS_ACTION": I8,
    "MIS_DONE_BEHAVE": I8, "ANGLE_MAX": I16,
    **{f"SR0_{g}": I16 for g in ("RAW_SENS", "EXT_STAT", "RC_CHAN", "RAW_CTRL", "POSITION", "EXTRA1",
                                 "EXTRA2", "EXTRA3", "PARAMS", "ADSB")},
}
UNITS = {
    "FS_GCS_TIMEOUT": "s", "BATT_CAPACITY": "mAh", "GUID_TIMEOUT": "s", "FENCE_RADIUS": "m",
    "FENCE_MARGIN": "m", "FENCE_ALT_MAX": "m", "FENCE_ALT_MIN": "m", "RTL_ALT": "cm", "RTL_SPEED": "cm/s",
    "LAND_SPEED": "cm/s", "LAND_SPEED_HIGH": "cm/s", "DISARM_DELAY": "s", "WPNAV_RADIUS": "cm",
    "CIRCLE_RATE": "deg/s", "RALLY_LIMIT_KM": "km", "SRTL_ACCURACY": "m", "PHLD_BRAKE_RATE": "deg/s",
    "PHLD_BRAKE_ANGLE": "cdeg", "WP_RADIUS": "m", "LOIT_RADIUS": "m", "SR0_EXTRA1": "Hz",
    "SIM_WIND_DIR_Z": "deg", "SIM_WIND_T_ALT": "m",
}
