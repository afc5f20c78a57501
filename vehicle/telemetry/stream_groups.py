"""ArduPilot's telemetry stream groups (SRx_* parameters), per vehicle kind.

As ArduPilot's GCS_MAVLink_Parameters.cpp (`STREAM_*_msgs`, master of 2025; 4.5's
ArduCopter/GCS_Mavlink.cpp and Rover/GCS_Mavlink.cpp list the same messages for what
towerlink simulates): which MAVLink messages each SR0_* rate schedules. A message whose
builder has nothing to say is not sent, as ArduPilot's senders return early (SCALED_PRESSURE3:
SITL has two barometers; WIND, ESC_TELEMETRY_1_TO_4 from a rover; PID_TUNING with
GCS_PID_MASK 0). ESC_TELEMETRY_1_TO_4 is in SR0_EXTRA1 as in master (4.5 lists it in
SR0_EXTRA3). Messages
ArduPilot lists but towerlink has no source for are left out: AIRSPEED (no sensor),
MCU_STATUS, GPS_RTK and GPS2_* (one plain GPS), RC_CHANNELS_RAW (MAVLink 1 links only),
RPM, WHEEL_DISTANCE, EFI, generator, winch (no such hardware), RANGEFINDER,
DISTANCE_SENSOR, WATER_DEPTH, TERRAIN_*, OPTICAL_FLOW, MAG_CAL_* (no rangefinder, terrain,
flow sensor or compass calibration), GIMBAL_DEVICE_ATTITUDE_STATUS, ADSB_VEHICLE and
AVAILABLE_MODES. Rover adds RC_CHANNELS_SCALED (MSG_SERVO_OUT) in SR0_RAW_CTRL.

ArduPilot's SITL answers MSG_SIMSTATE with SIMSTATE; towerlink streams SIM_STATE (its newer
form, which ArduPilot sends on request) beside it. towerlink also adds ATTITUDE_QUATERNION,
EXTENDED_SYS_STATE, POSITION_TARGET_LOCAL_NED and HOME_POSITION, which the bridge, MAVSDK
and the scorers want without asking.
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

_M = mav
_COMMON: dict[str, tuple[int, ...]] = {
    "SR0_RAW_SENS": (_M.MAVLINK_MSG_ID_RAW_IMU, _M.MAVLINK_MSG_ID_SCALED_IMU2, _M.MAVLINK_MSG_ID_SCALED_IMU3,
                     _M.MAVLINK_MSG_ID_SCALED_PRESSURE, _M.MAVLINK_MSG_ID_SCALED_PRESSURE2,
                     _M.MAVLINK_MSG_ID_SCALED_PRESSURE3),
    "SR0_EXT_STAT": (_M.MAVLINK_MSG_ID_SYS_STATUS, _M.MAVLINK_MSG_ID_POWER_STATUS, _M.MAVLINK_MSG_ID_MEMINFO,
                     _M.MAVLINK_MSG_ID_MISSION_CURRENT, _M.MAVLINK_MSG_ID_GPS_RAW_INT,
                     _M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, _M.MAVLINK_MSG_ID_FENCE_STATUS,
                     _M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT,
                     _M.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED, _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE),
    "SR0_RC_CHAN": (_M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, _M.MAVLINK_MSG_ID_RC_CHANNELS),
    "SR0_RAW_CTRL": (),
    "SR0_POSITION": (_M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, _M.MAVLINK_MSG_ID_LOCAL_POSITION_NED),
    "SR0_EXTRA1": (_M.MAVLINK_MSG_ID_ATTITUDE, _M.MAVLINK_MSG_ID_SIMSTATE, _M.MAVLINK_MSG_ID_SIM_STATE,
                   _M.MAVLINK_MSG_ID_AHRS2, _M.MAVLINK_MSG_ID_PID_TUNING, _M.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4,
                   _M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION),
    "SR0_EXTRA2": (_M.MAVLINK_MSG_ID_VFR_HUD,),
    "SR0_EXTRA3": (_M.MAVLINK_MSG_ID_AHRS, _M.MAVLINK_MSG_ID_WIND, _M.MAVLINK_MSG_ID_SYSTEM_TIME, _M.MAVLINK_MSG_ID_BATTERY_STATUS,
                   _M.MAVLINK_MSG_ID_EKF_STATUS_REPORT, _M.MAVLINK_MSG_ID_VIBRATION,
                   _M.MAVLINK_MSG_ID_HOME_POSITION),
}
_ROVER_EXTRA = {"SR0_RAW_CTRL": (_M.MAVLINK_MSG_ID_RC_CHANNELS_SCALED,)}

# REQUEST_DATA_STREAM stream ids -> group parameter (MAV_DATA_STREAM_ALL sets them all)
DATA_STREAMS = {
    _M.MAV_DATA_STREAM_RAW_SENSORS: "SR0_RAW_SENS",
    _M.MAV_DATA_STREAM_EXTENDED_STATUS: "SR0_EXT_STAT",
    _M.MAV_DATA_STREAM_RC_CHANNELS: "SR0_RC_CHAN",
    _M.MAV_DATA_STREAM_RAW_CONTROLLER: "SR0_RAW_CTRL",
    _M.MAV_DATA_STREAM_POSITION: "SR0_POSITION",
    _M.MAV_DATA_STREAM_EXTRA1: "SR0_EXTRA1",
    _M.MAV_DATA_STREAM_EXTRA2: "SR0_EXTRA2",
    _M.MAV_DATA_STREAM_EXTRA3: "SR0_EXTRA3",
}


def stream_groups(kind: str) -> dict[str, tuple[int, ...]]:
    """Group parameter -> the message ids it schedules, for a "copter" or a "rover"."""
    groups = dict(_COMMON)
    if kind == "rover":
        for g, ids in _ROVER_EXTRA.items():
            groups[g] = groups[g] + ids
    return groups
