"""ArduPilot SITL's injected faults (the SIM_* parameters of libraries/SITL/SITL.cpp,
SIM_GPS.cpp, SITL_Baro.cpp) as one vehicle's pure value, and what they do to its sensors and
motors. No clocks, no sockets: the fleet hands in the readings and the sim time.

Parameters (ArduPilot's names, units and defaults unless said):
- SIM_GPS1_ENABLE (1): 0 = the receiver has no lock: no fix is fused (SIM_GPS.cpp: have_lock
  false). Before ArduPilot 4.5 this was SIM_GPS_DISABLE; 4.5 dropped that name ("1 was
  GPS_DISABLE"), so towerlink has only the new one.
- SIM_GPS1_NUMSATS (10): satellites the receiver reports (GPS_RAW_INT); fewer than 4 is no
  3D fix here (ArduPilot's receiver keeps its lock: towerlink's simplification).
- SIM_GPS1_GLTCH_X/_Y/_Z (0): a step added to every fix: X degrees of latitude, Y degrees of
  longitude, Z metres of altitude (SIM_GPS.cpp adds them to lat, lon, alt).
- SIM_BARO_RND: baro noise, 1 sigma m (ArduPilot's default 0.2; towerlink's baro model is
  0.1 m and the default keeps it). SIM_BARO_DRIFT (m/s): the reading drifts by drift x sim
  time since boot (SITL_Baro.cpp). SIM_BARO_GLITCH (m): a step added. SIM_BARO_DISABLE: 1 =
  no baro readings.
- SIM_ACC1_RND (m/s/s), SIM_GYR1_RND (deg/s): extra accelerometer / gyro noise, 1 sigma
  (ArduPilot scales it with motor vibration; here it is white and always on).
- SIM_MAG1_FAIL, SIM_MAG_RND: stored only. The estimator fuses no compass (its heading is a
  modelled AHRS error), so a compass fault has nothing to act on.
- SIM_ENGINE_FAIL (bitmask of motors 1..32), SIM_ENGINE_MUL (0): each masked motor's output
  is multiplied by SIM_ENGINE_MUL (ArduPilot scales the servo output's 1000..2000 range by
  it, a rover's about 1500): a copter's rotor-speed command; a skid-steer rover's left
  (servo 1) and right (servo 3) throttle (skid_mix).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from common.geo import LATLON_TO_M

BARO_RND_DEFAULT = 0.1     # m: towerlink's baro model (vehicle.sensors.SensorSpec.baro_sigma)
MIN_3D_SATS = 4            # fewer satellites: no 3D fix

# (name, default, lo, hi, type, units, doc) rows for the parameter tables (params_ardupilot)
PARAM_ROWS = [
    ("SIM_GPS1_ENABLE", 1, 0, 1, "I8", "", "simulated GPS 1: 1 enabled, 0 no lock (no fix; the EKF loses position)"),
    ("SIM_GPS1_NUMSATS", 10, 0, 100, "I8", "", "satellites GPS 1 reports; fewer than 4 is no 3D fix"),
    ("SIM_GPS1_GLTCH_X", 0, -1, 1, "F", "deg", "GPS 1 glitch: latitude step added to every fix"),
    ("SIM_GPS1_GLTCH_Y", 0, -1, 1, "F", "deg", "GPS 1 glitch: longitude step added to every fix"),
    ("SIM_GPS1_GLTCH_Z", 0, -1000, 1000, "F", "m", "GPS 1 glitch: altitude step added to every fix"),
    ("SIM_BARO_RND", BARO_RND_DEFAULT, 0, 10, "F", "m", "baro noise, 1 sigma (ArduPilot's default 0.2)"),
    ("SIM_BARO_DRIFT", 0, -10, 10, "F", "m/s", "baro altitude drift rate (times sim time since boot)"),
    ("SIM_BARO_GLITCH", 0, -1000, 1000, "F", "m", "baro altitude step"),
    ("SIM_BARO_DISABLE", 0, 0, 1, "I8", "", "1: the baro gives no readings"),
    ("SIM_ACC1_RND", 0, 0, 10, "F", "m/s/s", "extra accelerometer noise, 1 sigma"),
    ("SIM_GYR1_RND", 0, 0, 100, "F", "deg/s", "extra gyro noise, 1 sigma"),
    ("SIM_MAG1_FAIL", 0, 0, 1, "I8", "", "compass 1 failed (not simulated: stored only; no compass is fused)"),
    ("SIM_MAG_RND", 0, 0, 100, "F", "", "compass noise factor (stored only: no magnetometer model)"),
    ("SIM_ENGINE_FAIL", 0, 0, 2**31 - 1, "I32", "", "bitmask of motors (1 = motor 1) SIM_ENGINE_MUL applies to"),
    ("SIM_ENGINE_MUL", 0, 0, 1, "F", "", "output multiplier of the SIM_ENGINE_FAIL motors (0 = dead)"),
]
NAMES = frozenset(r[0] for r in PARAM_ROWS)
DEFAULTS = {r[0]: float(r[1]) for r in PARAM_ROWS}


@dataclass(frozen=True)
class SimFaults:
    """One vehicle's injected faults, in towerlink's terms: gps_offset is world NED metres,
    motor_mul one multiplier per motor (ArduPilot order), noise sigmas in SI units."""
    gps_enabled: bool = True
    gps_numsats: int = 10
    gps_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)   # NED m added to the GPS position
    baro_disabled: bool = False
    baro_drift: float = 0.0          # m/s (height up, times sim time)
    baro_glitch: float = 0.0         # m (height up)
    baro_sigma: float = BARO_RND_DEFAULT
    accel_sigma: float = 0.0         # m/s/s, extra
    gyro_sigma: float = 0.0          # rad/s, extra
    motor_mul: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0)

    @classmethod
    def from_params(cls, values: Mapping[str, float], lat_deg: float, motors: int = 4) -> "SimFaults":
        """From a parameter store's values (missing names take their defaults); lat_deg turns
        the longitude glitch into metres east."""
        p = {**DEFAULTS, **{k: float(v) for k, v in values.items() if k in NAMES}}
        mask, mul = int(p["SIM_ENGINE_FAIL"]), p["SIM_ENGINE_MUL"]
        return cls(gps_enabled=p["SIM_GPS1_ENABLE"] != 0, gps_numsats=int(p["SIM_GPS1_NUMSATS"]),
                   gps_offset=(p["SIM_GPS1_GLTCH_X"] * LATLON_TO_M,
                               p["SIM_GPS1_GLTCH_Y"] * LATLON_TO_M * math.cos(math.radians(lat_deg)),
                               -p["SIM_GPS1_GLTCH_Z"]),
                   baro_disabled=p["SIM_BARO_DISABLE"] != 0, baro_drift=p["SIM_BARO_DRIFT"],
                   baro_glitch=p["SIM_BARO_GLITCH"], baro_sigma=max(p["SIM_BARO_RND"], 0.0),
                   accel_sigma=max(p["SIM_ACC1_RND"], 0.0), gyro_sigma=math.radians(max(p["SIM_GYR1_RND"], 0.0)),
                   motor_mul=tuple(mul if mask >> m & 1 else 1.0 for m in range(motors)))

    @property
    def gps_fix(self) -> bool:
        """A 3D fix: lock and enough satellites."""
        return self.gps_enabled and self.gps_numsats >= MIN_3D_SATS

    @property
    def motors_ok(self) -> bool:
        return all(m == 1.0 for m in self.motor_mul)

    @property
    def sensors_ok(self) -> bool:
        """Nothing changes the sensor readings (the fleet then skips the sensor hooks)."""
        return (self.gps_fix and self.gps_offset == (0.0, 0.0, 0.0) and not self.baro_disabled
                and self.baro_drift == 0.0 and self.baro_glitch == 0.0 and self.baro_sigma == BARO_RND_DEFAULT
                and self.accel_sigma == 0.0 and self.gyro_sigma == 0.0)


NONE = SimFaults()


def extra_sigma(base: float, total: float) -> float:
    """What to add to `base` x z so that the noise has sigma `total` (>= 0): readings that
    already carry base x z (a standard normal z) get (total - base) x z more."""
    return total - base


def combined_sigma(base: float, extra: float) -> float:
    """Sigma of base noise plus independent extra noise."""
    return math.sqrt(base * base + extra * extra)


def faulty_readings(f: SimFaults, t: float, z: list[float], slots: tuple[int, int], spec,
                    accel, gps_pos, gps_vel, baro_alt):
    """One vehicle's readings with its faults: (accel, gps_pos, gps_vel, baro_alt), each a
    tuple or None (no reading). z: this epoch's standard normals; slots: (accel slot, baro
    slot) in z; spec: the SensorSpec whose sigmas the readings carry; t: sim s since boot.
    The extra noise reuses the reading's own normal (the same draw, a wider spread), so the
    random streams are unchanged by a fault."""
    sa, sb = slots
    if f.accel_sigma:
        k = extra_sigma(spec.accel_sigma, combined_sigma(spec.accel_sigma, f.accel_sigma))
        accel = (accel[0] + k * z[sa], accel[1] + k * z[sa + 1], accel[2] + k * z[sa + 2])
    if gps_pos is not None:
        if not f.gps_fix:
            gps_pos = gps_vel = None
        else:
            o = f.gps_offset
            gps_pos = (gps_pos[0] + o[0], gps_pos[1] + o[1], gps_pos[2] + o[2])
    if baro_alt is not None:
        if f.baro_disabled:
            baro_alt = None
        else:
            baro_alt = (baro_alt + extra_sigma(spec.baro_sigma, f.baro_sigma) * z[sb]
                        + f.baro_glitch + f.baro_drift * t)
    return accel, gps_pos, gps_vel, baro_alt


def gyro_error(f: SimFaults, spec, bias, err):
    """A gyro error row (bias + sigma z) with the fault's extra noise: the same normal, wider."""
    if not f.gyro_sigma:
        return err
    k = extra_sigma(spec.gyro_sigma, combined_sigma(spec.gyro_sigma, f.gyro_sigma)) / spec.gyro_sigma
    return [e + k * (e - b) for e, b in zip(err, bias)]


def motor_multipliers(faults: list[SimFaults]) -> list | None:
    """Per vehicle its motors' output multipliers (None where all run at 1); None: all at 1."""
    muls = [None if f.motors_ok else f.motor_mul for f in faults]
    return None if all(m is None for m in muls) else muls


def skid_mix(speed, rate, mul_left: float, mul_right: float, max_speed, max_rate):
    """A skid-steer rover's (speed m/s, turn rate rad/s, positive right) command with its left
    (servo 1) and right (servo 3) throttles multiplied: ArduRover mixes left = throttle +
    steering, right = throttle - steering (each a fraction of full), SITL multiplies the
    failed outputs, the wheels' mean drives and their difference turns. Floats or arrays."""
    t, st = speed / max_speed, rate / max_rate
    left, right = (t + st) * mul_left, (t - st) * mul_right
    return 0.5 * (left + right) * max_speed, 0.5 * (left - right) * max_rate
