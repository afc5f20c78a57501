"""The simulation's truth as ArduPilot SITL reports it: SIMSTATE, SIM_STATE and WIND.

SIMSTATE and SIM_STATE (libraries/SITL/SITL.cpp simstate_send / sim_state_send): the physics'
own state, not the estimate. Attitude roll, pitch, yaw (rad; yaw wrapped to -pi..pi as
ArduPilot's DCM convention), the accelerometer's truth (specific force, body FRD, m/s^2; at
rest z = -9.8), body rates (rad/s FRD), position (lat/lon degE7; SIM_STATE also the float
degrees, the altitude AMSL in m and the NED velocity in m/s, and its std_dev fields 0).

WIND (GCS_MAVLINK_Copter::send_wind): ArduCopter reports the EKF3 wind estimate, and only
when EKF3 estimates wind (an airspeed vector exists: drag fusion or an airspeed sensor).
towerlink has no wind estimator; a copter reports the simulation's wind model instead, the
air velocity it flies in now (mean wind at its height plus its turbulence, the world's
vehicle/physics/wind.py; zero in still air), in ArduPilot's form: direction the wind comes
FROM in degrees (atan2 of the negated vector, -180..180), speed = the 3-D length (m/s),
speed_z = the vector's down component (m/s, NED: positive = sinking air). ArduRover sends
WIND only from a wind vane (sailboats): a rover has nothing to send.
"""
from __future__ import annotations

import math

from common import geo
from common.frames import euler_from_quaternion
from vehicle.telemetry.imu import specific_force_body
from vehicle.telemetry.wire import e7


def wind_fields_of(air: tuple[float, float, float]) -> tuple[float, float, float]:
    """WIND (direction deg the wind comes from, speed m/s, speed_z m/s) of an air velocity
    (world NED, m/s)."""
    n, e, d = air
    return (math.degrees(math.atan2(-e, -n)), math.sqrt(n * n + e * e + d * d), d)


class TruthTelemetry:
    """SIMSTATE, SIM_STATE and WIND of one vehicle (`ap`: its autopilot)."""

    def __init__(self, ap) -> None:
        self.ap = ap
        self._seen: tuple | None = None       # (fleet step time, _state) of the last reading

    def _state(self):
        """(row, (roll, pitch, yaw), specific force, (lat, lon, alt)) of the truth now; SIMSTATE
        and SIM_STATE are due in the same tick and share one reading."""
        ap = self.ap
        t = ap.fleet.sim_time
        seen = self._seen
        if seen is not None and seen[0] == t:
            return seen[1]
        row = ap.fleet.truth_row(ap.i)
        state = (row, euler_from_quaternion(row[6:10]), specific_force_body(row), geo.ned_to_lla(ap.origin, row[0:3]))
        self._seen = (t, state)
        return state

    def simstate_fields(self) -> tuple:
        row, (r, p, y), f, (lat, lon, _) = self._state()
        return (r, p, y, *f, *row[10:13], e7(lat), e7(lon))

    def sim_state_fields(self) -> tuple:
        row, (r, p, y), f, (lat, lon, alt) = self._state()
        qx, qy, qz, qw = row[6:10]
        return (qw, qx, qy, qz, r, p, y, *f, *row[10:13], lat, lon, alt, 0.0, 0.0, *row[3:6],
                e7(lat), e7(lon))

    def wind_fields(self) -> tuple | None:
        """WIND: a copter's air (module doc); None for a rover (no wind vane)."""
        ap = self.ap
        if ap.kind != "copter":
            return None
        air = ap.fleet.air
        if air is None:                   # still air (atan2f(-0, -0): -180, as ArduPilot's)
            return wind_fields_of((0.0, 0.0, 0.0))
        n, e, d = (float(v) for v in air[ap.i])
        return wind_fields_of((n, e, d))
