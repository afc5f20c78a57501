"""Telemetry: the messages a vehicle sends, built from its autopilot's state, and the
stream groups (ArduPilot's SRx_ parameters) that schedule them.

All time fields come from the world's sim clock: time_boot_ms / time_usec are sim time since
the world started; SYSTEM_TIME.time_unix_usec is the wall time at start plus sim time.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import MISSION
from vehicle.link.framing import Framer, layout
from vehicle.link.link_core import time_boot_ms
from vehicle.telemetry import version
from vehicle.telemetry.messages import message_builders
from vehicle.telemetry.stream_groups import DATA_STREAMS, stream_groups  # noqa: F401 (DATA_STREAMS re-exported)
from vehicle.telemetry.wire import wire_clamp as _i


# the stream groups (SR0_*) and REQUEST_DATA_STREAM's ids: vehicle/telemetry/stream_groups.py
STREAM_GROUPS = stream_groups("copter")

S = mav  # short alias for the sensor bits
SENSORS_PRESENT = (S.MAV_SYS_STATUS_SENSOR_3D_GYRO | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | S.MAV_SYS_STATUS_SENSOR_3D_MAG | S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
                   | S.MAV_SYS_STATUS_SENSOR_GPS | S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
                   | S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | S.MAV_SYS_STATUS_SENSOR_YAW_POSITION
                   | S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
                   | S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | S.MAV_SYS_STATUS_AHRS
                   | S.MAV_SYS_STATUS_SENSOR_BATTERY | S.MAV_SYS_STATUS_PREARM_CHECK)
POSITION_DEPENDENT = S.MAV_SYS_STATUS_SENSOR_GPS | S.MAV_SYS_STATUS_AHRS | S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL

CAPABILITIES = (mav.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | mav.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mav.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mav.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mav.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | mav.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
                | mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE | mav.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
                | mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mav.MAV_PROTOCOL_CAPABILITY_FTP | mav.MAV_PROTOCOL_CAPABILITY_COMPASS_CALIBRATION * 0)
FLIGHT_SW_VERSION = version.FLIGHT_SW_VERSION


class Telemetry:
    """Builds messages for one vehicle from its autopilot `ap`; `framer` packs them for its
    link, `clock` is the world's sim time (s), `unix_start_us` the unix time of sim t = 0.

    Each message has one builder, `<name>_fields()`: the field values in the order of
    pymavlink's constructor (None when not available now), or a list of such tuples for a
    message ArduPilot sends several of each time it is due (PID_TUNING: one per enabled
    axis). `frame(msgid)` packs them straight onto the wire (vehicle/link/framing.py: no
    message object); `build_all(msgid)`, `build(msgid)` and the `<name>()` methods give
    pymavlink message objects for replies and tests."""

    def __init__(self, ap, framer: Framer | None, clock: Callable[[], float] | None,
                 unix_start_us: int = 0) -> None:
        self.ap = ap
        self.framer = framer
        self.clock = clock
        self.unix_start_us = unix_start_us
        # msgid -> its field builder (the messages this vehicle can send on request or stream)
        self.builders = {
            mav.MAVLINK_MSG_ID_HEARTBEAT: self.heartbeat_fields,
            mav.MAVLINK_MSG_ID_SYS_STATUS: self.sys_status_fields,
            mav.MAVLINK_MSG_ID_GPS_RAW_INT: self.gps_raw_int_fields,
            mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self.global_position_int_fields,
            mav.MAVLINK_MSG_ID_LOCAL_POSITION_NED: self.local_position_ned_fields,
            mav.MAVLINK_MSG_ID_ATTITUDE: self.attitude_fields,
            mav.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: self.attitude_quaternion_fields,
            mav.MAVLINK_MSG_ID_VFR_HUD: self.vfr_hud_fields,
            mav.MAVLINK_MSG_ID_HOME_POSITION: self.home_position_fields,
            mav.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: self.extended_sys_state_fields,
            mav.MAVLINK_MSG_ID_SYSTEM_TIME: self.system_time_fields,
            mav.MAVLINK_MSG_ID_BATTERY_STATUS: self.battery_status_fields,
            mav.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: self.position_target_local_ned_fields,
            mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION: self.autopilot_version_fields,
            mav.MAVLINK_MSG_ID_MISSION_CURRENT: self.mission_current_fields,
            mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: self.gps_global_origin_fields,
        }
        # sensors, estimator health, outputs, navigation, board (vehicle/telemetry/)
        self.builders.update(message_builders(ap, lambda: self.clock()))
        self.groups = stream_groups(ap.kind if ap is not None else "copter")   # SR0_* -> message ids

    def build_all(self, msgid: int) -> list:
        """Every message object this id gives now, in the order they are sent ([] if none:
        unknown id, home unset)."""
        b = self.builders.get(msgid)
        v = None if b is None else b()
        if not v:
            return []
        cls = layout(msgid).cls
        return [cls(*f) for f in v] if type(v) is list else [cls(*v)]

    def build(self, msgid: int):
        """The (first) message object with this id, or None if not available now."""
        msgs = self.build_all(msgid)
        return msgs[0] if msgs else None

    def frame(self, msgid: int) -> bytes | None:
        """The message with this id framed for the link, or None if not available now. The
        caller advances the sequence number after it; several messages of one id (a list
        from the builder) come back as consecutive frames, the sequence number advanced
        between them here."""
        v = self.builders[msgid]()
        if not v:
            return None
        framer = self.framer
        if type(v) is not list:
            return framer.frame(msgid, v)
        m = framer.mav
        out = []
        for i, f in enumerate(v):
            if i:
                m.seq = (m.seq + 1) % 256
            out.append(framer.frame(msgid, f))
        return b"".join(out)

    def set_unix_start(self, unix_start_us: int) -> None:
        """Sim t = 0 is this unix time (us) from now on (SYSTEM_TIME.time_unix_usec)."""
        self.unix_start_us = unix_start_us

    # the message objects (replies, share_positions, tests)
    def heartbeat(self):
        return self.build(mav.MAVLINK_MSG_ID_HEARTBEAT)

    def sys_status(self):
        return self.build(mav.MAVLINK_MSG_ID_SYS_STATUS)

    def global_position_int(self):
        return self.build(mav.MAVLINK_MSG_ID_GLOBAL_POSITION_INT)

    def gps_global_origin(self):
        return self.build(mav.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)

    def battery_status(self):
        return self.build(mav.MAVLINK_MSG_ID_BATTERY_STATUS)

    def autopilot_version(self):
        return self.build(mav.MAVLINK_MSG_ID_AUTOPILOT_VERSION)

    def mission_current(self):
        return self.build(mav.MAVLINK_MSG_ID_MISSION_CURRENT)

    # time
    def boot_ms(self) -> int:
        return time_boot_ms(self.clock())

    def usec(self) -> int:
        return int(self.clock() * 1e6)

    # messages
    def mission_current_fields(self) -> tuple:
        """MISSION_CURRENT: seq, total (items after home, as ArduPilot), state, mission_mode
        (1 in AUTO)."""
        ap = self.ap
        seq, state = ap.mission_current()
        total = max(0, ap.missions.count(MISSION) - 1)
        return (int(seq), total, int(state), 1 if ap.mode_name == "AUTO" else 0)

    def heartbeat_fields(self) -> tuple:
        ap = self.ap
        return (ap.mav_type, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, ap.base_mode(),
                ap.mode, ap.system_status(), 3)

    def sys_status_fields(self) -> tuple:
        ap = self.ap
        health = SENSORS_PRESENT & ~(S.MAV_SYS_STATUS_PREARM_CHECK)
        if not ap.est_ok:
            health &= ~POSITION_DEPENDENT
        if ap.prearm_ok():
            health |= S.MAV_SYS_STATUS_PREARM_CHECK
        # geofence bits as ArduPilot's AC_Fence sys_status_*: present, enabled, healthy (not breached)
        f_present, f_enabled, f_healthy = ap.fence.sys_status_bits()
        present = SENSORS_PRESENT | (S.MAV_SYS_STATUS_GEOFENCE if f_present else 0)
        if f_healthy:
            health |= S.MAV_SYS_STATUS_GEOFENCE     # MAVProxy says "fence breach" when this clears
        enabled = SENSORS_PRESENT | (S.MAV_SYS_STATUS_GEOFENCE if f_enabled else 0)
        if not ap.armed:
            enabled &= ~S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
        # battery as ArduPilot: no monitor -> not present, voltage 0, current and remaining -1;
        # a battery failsafe clears its health bit
        b = ap.battery.reading(ap.params.values)
        if b.voltage is None:
            present &= ~S.MAV_SYS_STATUS_SENSOR_BATTERY
            enabled &= ~S.MAV_SYS_STATUS_SENSOR_BATTERY
            health &= ~S.MAV_SYS_STATUS_SENSOR_BATTERY
        elif b.failsafe:
            health &= ~S.MAV_SYS_STATUS_SENSOR_BATTERY
        return (present, enabled, health, 100, 0 if b.voltage is None else _i(b.voltage * 1000, 0, 65535),
                -1 if b.current is None else _i(b.current * 100, -1, 32767),
                -1 if b.remaining_pct is None else b.remaining_pct, 0, 0, 0, 0, 0, 0, 0, 0, 0)

    def gps_raw_int_fields(self) -> tuple:
        ap = self.ap
        lat, lon, alt = ap.lla()
        ok = ap.est_ok
        fault = ap.fleet.faults_of(ap.i)            # SIM_GPS1_* (vehicle/sim_faults.py)
        ok = ok and fault.gps_fix
        vx, vy, _ = ap.vel.tolist()
        gs = float(np.hypot(vx, vy))
        cog = math.degrees(math.atan2(vy, vx)) % 360.0 if gs > 0.2 else 0.0
        return (self.usec(), mav.GPS_FIX_TYPE_3D_FIX if ok else mav.GPS_FIX_TYPE_NO_FIX,
                _i(lat * 1e7, -2**31, 2**31 - 1) if ok else 0, _i(lon * 1e7, -2**31, 2**31 - 1) if ok else 0,
                _i(alt * 1000, -2**31, 2**31 - 1) if ok else 0, 121 if ok else 65535, 200 if ok else 65535,
                _i(gs * 100, 0, 65534), _i(cog * 100, 0, 35999), fault.gps_numsats if fault.gps_enabled else 0,
                _i(alt * 1000, -2**31, 2**31 - 1), 300, 500, 100, 0, 0)

    def global_position_int_fields(self) -> tuple:
        ap = self.ap
        lat, lon, alt = ap.lla()
        home_alt = ap.home_lla()[2]
        hdg = math.degrees(ap.yaw) % 360.0
        vx, vy, vz = ap.vel.tolist()
        return (self.boot_ms(), _i(lat * 1e7, -2**31, 2**31 - 1), _i(lon * 1e7, -2**31, 2**31 - 1),
                _i(alt * 1000, -2**31, 2**31 - 1), _i((alt - home_alt) * 1000, -2**31, 2**31 - 1),
                _i(vx * 100, -32768, 32767), _i(vy * 100, -32768, 32767),
                _i(vz * 100, -32768, 32767), _i(hdg * 100, 0, 35999))

    def local_position_ned_fields(self) -> tuple | None:
        # NED from this vehicle's EKF origin; none before it is set (ArduPilot has no local
        # position then either)
        ap = self.ap
        if not ap.local_origin.is_set:
            return None
        return (self.boot_ms(), *ap.local_origin.to_local(ap.pos).tolist(), *ap.vel.tolist())

    def attitude_fields(self) -> tuple:
        ap = self.ap
        return (self.boot_ms(), *ap.euler, *ap.rates.tolist())

    def attitude_quaternion_fields(self) -> tuple:
        ap = self.ap
        x, y, z, w = ap.quat.tolist()
        return (self.boot_ms(), w, x, y, z, *ap.rates.tolist(), [0.0, 0.0, 0.0, 0.0])

    def vfr_hud_fields(self) -> tuple:
        ap = self.ap
        vx, vy, vz = ap.vel.tolist()
        gs = float(np.hypot(vx, vy))
        thr = 0 if not ap.armed else (15 if ap.on_ground else 50)
        return (gs, gs, _i(math.degrees(ap.yaw) % 360.0, 0, 359), thr, float(ap.lla()[2]), -vz)

    def home_position_fields(self) -> tuple | None:
        ap = self.ap
        if ap.home is None:
            return None
        lat, lon, alt = ap.home_lla()
        h = ap.local_origin.to_local(ap.home)       # x, y, z: home in the local (EKF origin) frame
        return (_i(lat * 1e7, -2**31, 2**31 - 1), _i(lon * 1e7, -2**31, 2**31 - 1), _i(alt * 1000, -2**31, 2**31 - 1),
                float(h[0]), float(h[1]), float(h[2]), [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, self.usec())

    def gps_global_origin_fields(self) -> tuple | None:
        """Where the vehicle's local NED (0, 0, 0) is; None until the EKF origin is set."""
        o = self.ap.ekf_origin()
        if o is None:
            return None
        lat, lon, alt = o
        return (_i(lat * 1e7, -2**31, 2**31 - 1), _i(lon * 1e7, -2**31, 2**31 - 1),
                _i(alt * 1000, -2**31, 2**31 - 1), self.usec())

    def extended_sys_state_fields(self) -> tuple:
        return (mav.MAV_VTOL_STATE_UNDEFINED, self.ap.landed_state())

    def system_time_fields(self) -> tuple:
        # one clock reading for both fields: time_unix_usec - time_boot_ms * 1000 is then the
        # world's start in unix time (to the ms truncation of time_boot_ms), the offset a
        # bridge uses to put vehicles of different worlds/processes on one timeline
        t = self.clock()
        return (int(self.unix_start_us + int(t * 1e6)),
                int(t * 1000.0) & 0xFFFFFFFF)

    def battery_status_fields(self) -> tuple | None:
        """As ArduPilot's send_battery_status: no cell voltages, so voltages[0] is the pack
        (mV), the rest UINT16_MAX; energy in hJ; -1 where the monitor cannot measure;
        charge_state from the battery failsafe. None with BATT_MONITOR 0 (no battery)."""
        ap = self.ap
        r = ap.battery.reading(ap.params.values)
        if r.voltage is None:
            return None
        state = {0: mav.MAV_BATTERY_CHARGE_STATE_OK, 1: mav.MAV_BATTERY_CHARGE_STATE_LOW,
                 2: mav.MAV_BATTERY_CHARGE_STATE_CRITICAL}[r.failsafe]
        return (0, mav.MAV_BATTERY_FUNCTION_ALL, mav.MAV_BATTERY_TYPE_LIPO, 32767,
                [_i(r.voltage * 1000, 0, 65534)] + [65535] * 9,
                -1 if r.current is None else _i(r.current * 100, -1, 32767),
                -1 if r.consumed_mah is None else _i(r.consumed_mah, -1, 2**31 - 1),
                -1 if r.consumed_wh is None else _i(r.consumed_wh * 36, -1, 2**31 - 1),
                -1 if r.remaining_pct is None else r.remaining_pct,
                0 if r.time_remaining is None else _i(r.time_remaining, 0, 2**31 - 1),
                state, [0, 0, 0, 0], 0, 0)

    def position_target_local_ned_fields(self) -> tuple | None:
        ap = self.ap
        t = ap.echo
        if t is None:
            return None
        p = ap.local_origin.to_local(t.pos) if t.pos is not None else (0.0, 0.0, 0.0)
        v = t.vel if t.vel is not None else (0.0, 0.0, 0.0)
        a = t.acc if t.acc is not None else (0.0, 0.0, 0.0)
        return (self.boot_ms(), mav.MAV_FRAME_LOCAL_NED, t.type_mask, float(p[0]), float(p[1]), float(p[2]),
                float(v[0]), float(v[1]), float(v[2]), float(a[0]), float(a[1]), float(a[2]),
                float(t.yaw or 0.0), float(t.yaw_rate or 0.0))

    def autopilot_version_fields(self) -> tuple:
        ap = self.ap
        return (CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, version.custom_version_bytes(), [0] * 8, [0] * 8, 0, 0,
                0x746C0000 + ap.sysid, [0] * 18)
