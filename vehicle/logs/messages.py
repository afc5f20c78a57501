"""The log messages towerlink writes, with ArduPilot's names, formats, labels, units and
multipliers (ArduCopter / Rover 4.5: libraries/AP_Logger/LogStructure.h and the
LogStructure.h of AP_AHRS, AP_GPS, AP_BattMonitor, AP_NavEKF3; ArduCopter/Log.cpp for CTUN,
Rover/Log.cpp for THR), the unit and multiplier tables, and LogEvent / ModeReason ids.

Reading the values: see vehicle/logs/dataflash.py (what `pack` takes for each format
character). Angles in ATT and XKF1 are degrees (stored centidegrees); CTUN's DCRt / CRt
are cm/s (stored as int16 with multiplier 1e-2), BAlt metres (stored centimetres).
"""
from __future__ import annotations

from vehicle.logs.dataflash import MessageDef, Schema

# log_Units: id -> label
UNITS: list[tuple[str, str]] = [
    ("-", ""), ("?", "UNKNOWN"), ("A", "A"), ("a", "Ah"), ("d", "deg"), ("b", "B"),
    ("k", "deg/s"), ("D", "deglatitude"), ("e", "deg/s/s"), ("E", "rad/s"), ("G", "Gauss"),
    ("h", "degheading"), ("i", "A.s"), ("J", "W.s"), ("l", "l"), ("L", "rad/s/s"), ("m", "m"),
    ("n", "m/s"), ("o", "m/s/s"), ("O", "degC"), ("%", "%"), ("S", "satellites"), ("s", "s"),
    ("q", "rpm"), ("r", "rad"), ("U", "deglongitude"), ("u", "ppm"), ("v", "V"), ("P", "Pa"),
    ("w", "Ohm"), ("W", "Watt"), ("X", "W.h"), ("y", "l/s"), ("Y", "us"), ("z", "Hz"),
    ("#", "instance"),
]
# log_Multipliers: id -> factor applied to the stored value
MULTS: list[tuple[str, float]] = [
    ("-", 0.0), ("?", 1.0), ("2", 1e2), ("1", 1e1), ("0", 1e0), ("A", 1e-1), ("B", 1e-2),
    ("C", 1e-3), ("D", 1e-4), ("E", 1e-5), ("F", 1e-6), ("G", 1e-7), ("I", 1e-9),
    ("!", 3.6), ("/", 3600.0),
]

_C14 = ",".join(f"C{i}" for i in range(1, 15))

PARM = MessageDef("PARM", "QNff", "TimeUS,Name,Value,Default", "s---", "F---")
MSG = MessageDef("MSG", "QZ", "TimeUS,Message", "s-", "F-")
MODE = MessageDef("MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn", "s---", "F---")
EV = MessageDef("EV", "QB", "TimeUS,Id", "s-", "F-")
ARM = MessageDef("ARM", "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method", "s----", "F----")
CMD = MessageDef("CMD", "QHHHffffLLfB", "TimeUS,CTot,CNum,CId,Prm1,Prm2,Prm3,Prm4,Lat,Lng,Alt,Frame",
                 "s-------DUm-", "F-------GG0-")
GPS = MessageDef("GPS", "QBBIHBcLLeffffB", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U",
                 "s#-s-S-DUmnhnh-", "F--C-0BGGB000--")
ATT = MessageDef("ATT", "QccccCCCCB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF",
                 "sddddhhdh-", "FBBBBBBBB-")
POS = MessageDef("POS", "QLLfff", "TimeUS,Lat,Lng,Alt,RelHomeAlt,RelOriginAlt", "sDUmmm", "FGG000")
ORGN = MessageDef("ORGN", "QBLLe", "TimeUS,Type,Lat,Lng,Alt", "s-DUm", "F-GGB")
BAT = MessageDef("BAT", "QBfffffcf", "TimeUS,Instance,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res",
                 "s#vvAiJOw", "F-000!/?0")
RCIN = MessageDef("RCIN", "QHHHHHHHHHHHHHH", "TimeUS," + _C14, "s" + "Y" * 14, "F" + "-" * 14)
RCOU = MessageDef("RCOU", "QHHHHHHHHHHHHHH", "TimeUS," + _C14, "s" + "Y" * 14, "F" + "-" * 14)
XKF1 = MessageDef("XKF1", "QBccCfffffffccce", "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ,OH",
                  "s#ddhnnnnmmmkkkm", "F-BBB0000000BBBB")
CTUN = MessageDef("CTUN", "Qffffffefffhh", "TimeUS,ThI,ABst,ThO,ThH,DAlt,Alt,BAlt,DSAlt,SAlt,TAlt,DCRt,CRt",
                  "s----mmmmmmnn", "F----00B000BB")
THR = MessageDef("THR", "Qhffff", "TimeUS,ThrIn,ThrOut,DesSpeed,Speed,AccY", "s--nno", "F--000")

COMMON = [PARM, MSG, MODE, EV, ARM, CMD, GPS, ATT, POS, ORGN, BAT, RCIN, RCOU, XKF1]
COPTER = COMMON + [CTUN]
ROVER = COMMON + [THR]


def schema(kind: str) -> Schema:
    """The schema of a copter's or a rover's log."""
    return Schema(COPTER if kind == "copter" else ROVER, UNITS, MULTS)


# AP_Logger.h enum class LogEvent (the EV message's Id)
EV_ARMED = 10
EV_DISARMED = 11
EV_AUTO_ARMED = 15
EV_LAND_COMPLETE = 18
EV_NOT_LANDED = 28
EV_SET_HOME = 25

# ORGN.Type: AP_AHRS::LogOriginType
ORIGIN_EKF = 0
ORIGIN_AHRS_HOME = 1

# AP_Arming::Method (the ARM record's Method): how it was armed or why it disarmed; towerlink
# arms by MAVLink only, and disarms for the reasons the autopilot gives
ARM_METHOD_MAVLINK = 1
ARM_METHOD_UNKNOWN = 100
DISARM_METHODS = {"": ARM_METHOD_MAVLINK, "flight termination": 5, "battery failsafe": 7, "crash": 12, "landed": 13,
                  "mission complete": 14, "fence breach": 15, "auto-disarm": 17, "GCS failsafe": 18}

# ModeReason (MODE.Rsn) of the reasons the autopilot gives set_mode
MODE_REASON_UNKNOWN = 0
MODE_REASONS = {"RC": 1, "GCS": 2, "radio failsafe": 3, "battery failsafe": 4, "GCS failsafe": 5,
                "EKF failsafe": 6, "mission complete": 8, "fence breach": 10}


def disarm_method(reason: str) -> int:
    """ARM.Method of a disarm for `reason` (the autopilot's "Disarming motors: <reason>")."""
    return DISARM_METHODS.get(reason, ARM_METHOD_UNKNOWN)


def mode_reason(reason: str) -> int:
    """MODE.Rsn (ArduPilot's ModeReason) of a set_mode reason."""
    return MODE_REASONS.get(reason, MODE_REASON_UNKNOWN)
