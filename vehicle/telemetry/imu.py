"""Raw sensors as ArduPilot reports them: RAW_IMU (IMU 0), SCALED_IMU2 (IMU 1),
SCALED_IMU3 (compass 2 only), SCALED_PRESSURE / SCALED_PRESSURE2 (barometers 0 and 1) and
VIBRATION.

The instances are ArduPilot SITL's defaults: SIM_IMU_COUNT 2 (two IMUs), three compasses
(SIM_MAG1..3_DEVID set) and SIM_BARO_COUNT 2 (two barometers). ArduPilot's send_scaled_imu
sends an instance when the IMU or the compass exists, zeros for what does not: SITL's
SCALED_IMU3 carries compass 2's field with accelerometer, gyro and temperature 0. Its
send_scaled_pressure_instance sends nothing for a barometer that does not exist (and no
airspeed sensor): no SCALED_PRESSURE3.

Readings are sampled when the message is built, from the true state (the fleet's
`truth_row`) through the sensor models of vehicle/sensors.py: IMU 0 is the estimator's
accelerometer and gyro (their constant biases, the spec's white noise); IMU 1 is a second
unit of the same model with its own biases (ArduPilot SITL simulates two IMUs as well).
The noise of these telemetry samples comes from the vehicle's own generator, so reading
telemetry never disturbs the estimator's noise streams.

- Specific force body FRD, m/s^2 -> milli-g (x 1000 / 9.80665; at rest z is about -1000).
- Rates body FRD rad/s -> mrad/s.
- Magnetic field: an axial dipole Earth field (0.3 G at the equator, no declination) at the
  world origin's latitude, rotated into the body, in milligauss (ArduPilot's compass units).
- Temperatures: 25 degC for the IMUs and the barometer's air at ISA, cdegC.
- Pressure: the ISA pressure at the barometer's altitude (true altitude AMSL + the spec's
  baro noise, drawn for each barometer), hPa; no airspeed sensor, so press_diff is 0.
- Vibration: ArduPilot's vibration level (the 2 Hz mean square of the accelerometer minus
  its 5 Hz low-pass) of the accelerometer's white noise: its standard deviation, m/s^2, on
  each axis; the simulated motors do not shake the airframe. No clipping (the IMU range
  is never reached in the simulation).
"""
from __future__ import annotations

import math

import numpy as np

from common.frames.batch import rotate_one
from vehicle.telemetry.wire import boot_ms, usec, wire_clamp

GRAVITY = 9.80665
MG_PER_MS2 = 1000.0 / GRAVITY
DIPOLE_MG = 300.0
IMU_TEMP_CDEG = 2500
I16 = (-32768, 32767)


def dipole_field_ned(lat_deg: float) -> tuple[float, float, float]:
    """An axial dipole's field at latitude lat_deg, NED, milligauss."""
    lat = math.radians(lat_deg)
    return (DIPOLE_MG * math.cos(lat), 0.0, 2.0 * DIPOLE_MG * math.sin(lat))


def specific_force_body(row) -> tuple[float, float, float]:
    """What an accelerometer feels (m/s^2, body FRD; at rest z = -g) from a truth row
    (fleet.truth_row: quaternion in 6:10, acceleration world NED in 13:16)."""
    qx, qy, qz, qw = row[6:10]
    return rotate_one(qx, qy, qz, qw, row[13], row[14], row[15] - GRAVITY, -1.0)


def isa_pressure_pa(alt_m: float) -> float:
    """International Standard Atmosphere pressure (Pa) at alt_m AMSL (troposphere)."""
    return 101325.0 * (1.0 - 2.25577e-5 * alt_m) ** 5.25588


def isa_temperature_c(alt_m: float) -> float:
    """ISA air temperature (degC) at alt_m AMSL (troposphere)."""
    return 15.0 - 0.0065 * alt_m


class ImuTelemetry:
    """The raw-sensor messages of one vehicle (`ap`: its autopilot; clock: sim s)."""

    def __init__(self, ap, clock) -> None:
        self.ap = ap
        self.clock = clock
        self._rng: np.random.Generator | None = None
        self._imu1_bias: list[float] | None = None
        self._field: tuple[float, float, float] | None = None
        self._samples: dict[str, tuple[float, object]] = {}

    def _noise(self, k: int) -> np.ndarray:
        if self._rng is None:       # per vehicle, seeded by its index and sysid: reproducible
            self._rng = np.random.default_rng([0x746C, self.ap.i, self.ap.sysid])
        return self._rng.standard_normal(k)

    def _spec(self):
        return self.ap.fleet.spec

    def _sample(self, key: str, t: float, draw):
        """One sample per sensor and sim instant: a message built twice at one time (a
        request and a stream in the same tick) carries the same reading."""
        hit = self._samples.get(key)
        if hit is None or hit[0] != t:
            hit = self._samples[key] = (t, draw())
        return hit[1]

    def _imu(self, unit: int) -> tuple[tuple, tuple, tuple]:
        """(specific force m/s^2, rates rad/s, field mG), body FRD, of IMU `unit` now."""
        fleet, i, sp = self.ap.fleet, self.ap.i, self._spec()
        row = fleet.truth_row(i)
        qx, qy, qz, qw = row[6:10]
        if self._field is None:
            self._field = dipole_field_ned(self.ap.origin[0])
        f_body = specific_force_body(row)
        field = rotate_one(qx, qy, qz, qw, *self._field, -1.0)
        if unit == 0:
            s = getattr(fleet, "sensors", None)
            bias = (s.accel_bias[i].tolist() + s.gyro_bias[i].tolist()) if s is not None else [0.0] * 6
        else:
            if self._imu1_bias is None:
                b = self._noise(6).tolist()
                self._imu1_bias = [v * sp.accel_bias_sigma for v in b[:3]] + [v * sp.gyro_bias_sigma for v in b[3:]]
            bias = self._imu1_bias
        z = self._noise(6).tolist()
        acc = tuple(f + b + sp.accel_sigma * n for f, b, n in zip(f_body, bias[:3], z[:3]))
        gyro = tuple(w + b + sp.gyro_sigma * n for w, b, n in zip(row[10:13], bias[3:], z[3:]))
        return acc, gyro, field

    def _scaled(self, unit: int, t: float) -> list[int]:
        acc, gyro, field = self._sample(f"imu{unit}", t, lambda: self._imu(unit))
        return ([wire_clamp(a * MG_PER_MS2, *I16) for a in acc]
                + [wire_clamp(w * 1000.0, *I16) for w in gyro]
                + [wire_clamp(m, *I16) for m in field])

    def raw_imu_fields(self) -> tuple:
        """RAW_IMU: IMU 0 (ArduPilot fills it with scaled units, as here), id 0."""
        t = self.clock()
        return (usec(t), *self._scaled(0, t), 0, IMU_TEMP_CDEG)

    def scaled_imu2_fields(self) -> tuple:
        """SCALED_IMU2: IMU 1 and the compass."""
        t = self.clock()
        return (boot_ms(t), *self._scaled(1, t), IMU_TEMP_CDEG)

    def scaled_imu3_fields(self) -> tuple:
        """SCALED_IMU3: SITL has no third IMU, only a third compass (same field)."""
        t = self.clock()
        field = self._sample("imu1", t, lambda: self._imu(1))[2]
        return (boot_ms(t), 0, 0, 0, 0, 0, 0, *[wire_clamp(m, *I16) for m in field], 0)

    def _pressure(self, unit: int) -> tuple:
        """SCALED_PRESSURE(2): barometer `unit`, hPa and cdegC; no differential pressure sensor."""
        t = self.clock()
        alt = self._sample(f"baro{unit}", t, self._baro_alt)
        temp = wire_clamp(isa_temperature_c(alt) * 100.0, *I16)
        return (boot_ms(t), isa_pressure_pa(alt) / 100.0, 0.0, temp, 0)

    def scaled_pressure_fields(self) -> tuple:
        return self._pressure(0)

    def scaled_pressure2_fields(self) -> tuple:
        return self._pressure(1)

    def scaled_pressure3_fields(self) -> None:
        """SITL's SIM_BARO_COUNT is 2: no third barometer, nothing to send (None)."""

    def _baro_alt(self) -> float:
        """The barometer's altitude (m AMSL): the truth plus the spec's noise."""
        row = self.ap.fleet.truth_row(self.ap.i)
        return self.ap.origin[2] - row[2] + self._spec().baro_sigma * float(self._noise(1)[0])

    def vibration_fields(self) -> tuple:
        """VIBRATION: the accelerometer's noise level on each axis (m/s^2), no clipping."""
        v = float(self._spec().accel_sigma)
        return (usec(self.clock()), v, v, v, 0, 0, 0)
