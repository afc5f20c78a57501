"""Wind as ArduPilot's SITL models it (SIM_WIND_*), one air mass per world, seeded.

Frames and signs
- The result is the AIR VELOCITY: the velocity of the air mass over the ground, world NED,
  m/s. SIM_WIND_DIR is the direction the wind comes FROM (degrees, 0 north, 90 east, as a
  weather report and as ArduPilot), so SIM_WIND_DIR 270 (a westerly) moves the air east:
  air velocity (0, +speed, 0). (ArduPilot's SITL keeps the opposite vector, wind_ef, and
  adds it to the vehicle velocity; the air-relative velocity v - air is the same.)
- SIM_WIND_DIR_Z tilts the wind vertically (degrees, positive = the air rises, as ArduPilot:
  its NED z component is negative).

Model (learned from libraries/SITL/SIM_Aircraft.cpp update_wind and the SITL input stage)
- Profile with height above home h (SIM_WIND_T): 0 square law: below SIM_WIND_T_ALT the
  speed is scaled by sqrt(h / SIM_WIND_T_ALT); 1 none: the same speed at every height;
  2 linear: speed + (h - SIM_WIND_T_ALT) * SIM_WIND_T_COEF. Never negative.
- Parameter changes reach the air through a first-order lag (SMOOTH_TAU) on the wind
  vector, as ArduPilot low-passes the active wind ("the EKF does not like step inputs");
  filtering the vector, not the angle, avoids the long way round through 0/360 degrees.
- Turbulence (SIM_WIND_TURB, m/s): added to each airborne vehicle's air velocity, three
  independent first-order Gauss-Markov processes (north, east, down) with standard
  deviation SIM_WIND_TURB, as ArduPilot scales its turbulence to that standard deviation.
  Deviation, stated: ArduPilot filters white noise with a per-frame coefficient (0.98 per
  physics frame, about 40 ms at 1200 Hz) and scrambles the horizontal direction every
  frame, which makes its turbulence nearly white; here its correlation time is TURB_TAU
  (0.5 s) whatever the physics rate, so gusts are gusts a position controller feels and
  the result does not depend on --rate. Each vehicle has its own turbulence, drawn from its
  own generator seeded [world seed, "WIND", vehicle index], so a run is repeatable and a
  vehicle feels the same gusts whichever `--workers` process runs it.
- A vehicle on the ground feels no wind force (its ground contact holds it); the physics
  cores apply that rule.

Pure: numpy only, no clocks; the world calls air_velocity() at its autopilot rate.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

SMOOTH_TAU = 0.02     # s: lag of the mean wind behind SIM_WIND_SPD / SIM_WIND_DIR changes
TURB_TAU = 0.5        # s: correlation time of the turbulence
BLOCK = 64            # ticks of turbulence draws fetched per vehicle at a time
_WIND_TAG = 0x57494E44   # "WIND": keeps these streams apart from the sensors' [seed, j]

WIND_TYPE_SQRT, WIND_TYPE_NO_LIMIT, WIND_TYPE_COEF = 0, 1, 2


@dataclass(frozen=True)
class WindParams:
    """SIM_WIND_* values (ArduPilot names and units)."""
    speed: float = 0.0          # SIM_WIND_SPD, m/s
    direction: float = 180.0    # SIM_WIND_DIR, deg, where the wind comes from
    turbulence: float = 0.0     # SIM_WIND_TURB, m/s (standard deviation)
    dir_z: float = 0.0          # SIM_WIND_DIR_Z, deg, positive = rising air
    type: int = WIND_TYPE_SQRT  # SIM_WIND_T: 0 square law, 1 none, 2 linear
    t_alt: float = 60.0         # SIM_WIND_T_ALT, m: full strength at and above this height
    t_coef: float = 0.01        # SIM_WIND_T_COEF, (m/s)/m for the linear profile

    NAMES = {"SIM_WIND_SPD": "speed", "SIM_WIND_DIR": "direction", "SIM_WIND_TURB": "turbulence",
             "SIM_WIND_DIR_Z": "dir_z", "SIM_WIND_T": "type", "SIM_WIND_T_ALT": "t_alt",
             "SIM_WIND_T_COEF": "t_coef"}

    @classmethod
    def from_params(cls, p: Mapping[str, float]) -> "WindParams":
        """From a parameter mapping; names it lacks keep their defaults."""
        kw = {}
        for name, field_ in cls.NAMES.items():
            if name in p:
                v = float(p[name])
                kw[field_] = int(round(v)) if field_ == "type" else v
        return cls(**kw)

    def as_params(self) -> dict[str, float]:
        return {name: float(getattr(self, f)) for name, f in self.NAMES.items()}

    @property
    def calm(self) -> bool:
        """No mean wind and no turbulence at any height."""
        return self.turbulence <= 0.0 and (self.speed <= 0.0 and (self.type != WIND_TYPE_COEF or self.t_coef == 0.0))


def parse_wind(text: str) -> WindParams:
    """'SPD,DIR[,TURB]' (m/s, degrees the wind comes from, m/s) -> WindParams; ValueError
    naming what is wrong."""
    parts = [s.strip() for s in str(text).split(",")]
    if len(parts) not in (2, 3):
        raise ValueError(f"expected SPEED,DIRECTION[,TURBULENCE], got {text!r}")
    try:
        vals = [float(s) for s in parts]
    except ValueError:
        raise ValueError(f"wind values must be numbers, got {text!r}") from None
    return wind_from_values(*vals)


def wind_from_values(speed: float, direction: float, turbulence: float = 0.0, **extra) -> WindParams:
    """Checked WindParams from numbers (the scenario's wind table and --wind use it)."""
    for name, v in (("speed", speed), ("direction", direction), ("turbulence", turbulence)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ValueError(f"wind {name} must be a finite number, got {v!r}")
    if not 0.0 <= speed <= 40.0:
        raise ValueError(f"wind speed {speed:g} m/s is outside 0..40 (SIM_WIND_SPD)")
    if not 0.0 <= direction <= 360.0:
        raise ValueError(f"wind direction {direction:g} deg is outside 0..360 (SIM_WIND_DIR, where it comes from)")
    if not 0.0 <= turbulence <= 10.0:
        raise ValueError(f"wind turbulence {turbulence:g} m/s is outside 0..10 (SIM_WIND_TURB)")
    return WindParams(speed=float(speed), direction=float(direction), turbulence=float(turbulence), **extra)


def profile_speed(p: WindParams, height: np.ndarray | float) -> np.ndarray:
    """Mean wind speed (m/s) at `height` m above home, by SIM_WIND_T."""
    h = np.asarray(height, float)
    s = np.full_like(h, p.speed)
    if p.type == WIND_TYPE_SQRT:
        if p.t_alt > 0:
            s = np.where(h < p.t_alt, p.speed * np.sqrt(np.maximum(h / p.t_alt, 0.0)), s)
    elif p.type == WIND_TYPE_COEF:
        s = s + (h - p.t_alt) * p.t_coef
    return np.maximum(s, 0.0)


def air_direction(p: WindParams) -> np.ndarray:
    """Unit vector (NED) the air moves along: away from SIM_WIND_DIR, tilted by SIM_WIND_DIR_Z."""
    d, z = math.radians(p.direction), math.radians(p.dir_z)
    return np.array([-math.cos(d) * math.cos(z), -math.sin(d) * math.cos(z), -math.sin(z)])


class WindField:
    """The air of one world: mean wind (lagged behind its parameters) and each vehicle's
    turbulence, from one seeded generator."""

    def __init__(self, params: WindParams | None = None, seed: int = 0) -> None:
        self.params = params or WindParams()
        self.seed = int(seed) & 0xFFFFFFFF
        self._rngs: dict[int, np.random.Generator] = {}
        self._blocks: dict[object, list] = {}
        self._dir = air_direction(self.params)      # lagged unit-ish vector x speed below
        self._mean = self.params.speed              # lagged reference speed
        self._turb: dict[object, np.ndarray] = {}

    def set(self, params: WindParams) -> None:
        """New SIM_WIND_* values; the air follows within SMOOTH_TAU."""
        self.params = params

    @property
    def active(self) -> bool:
        """Anything to apply (the cores skip the air entirely when False)."""
        return not self.params.calm or abs(self._mean) > 1e-6

    def advance(self, dt: float) -> None:
        """Move the mean wind dt seconds towards its parameters (once per world tick)."""
        k = 1.0 - math.exp(-dt / SMOOTH_TAU)
        self._dir = self._dir + (air_direction(self.params) - self._dir) * k
        self._mean = self._mean + (self.params.speed - self._mean) * k

    def _normals(self, key, ids) -> np.ndarray:
        """(n,3) standard normals for this tick, one row per vehicle from its own stream."""
        b = self._blocks.get(key)
        if b is None or b[1] >= BLOCK or b[0].shape[1] != len(ids):
            rows = []
            for i in ids:
                g = self._rngs.get(i)
                if g is None:
                    g = self._rngs[i] = np.random.default_rng([self.seed, _WIND_TAG, int(i)])
                rows.append(g.standard_normal((BLOCK, 3)))
            b = self._blocks[key] = [np.stack(rows, axis=1), 0]
        out = b[0][b[1]]
        b[1] += 1
        return out

    def air_velocity(self, key, height: np.ndarray, airborne: np.ndarray, dt: float,
                     ids=None) -> np.ndarray:
        """(n,3) air velocity, world NED m/s, for the n vehicles of group `key` at `height`
        m above home; turbulence only where `airborne`, advanced by dt (call once per
        group per world tick, after advance()). ids: the vehicles' world indices (their
        turbulence streams; default 0..n-1)."""
        p = self.params
        h = np.asarray(height, float)
        lagged = WindParams(**{**p.__dict__, "speed": self._mean})
        out = profile_speed(lagged, h)[:, None] * self._dir[None, :]
        n = h.shape[0]
        t = self._turb.get(key)
        if t is None or t.shape[0] != n:
            t = self._turb[key] = np.zeros((n, 3))
        if p.turbulence > 0.0:
            a = math.exp(-dt / TURB_TAU)
            t *= a
            t += p.turbulence * math.sqrt(1.0 - a * a) * self._normals(key, range(n) if ids is None else ids)
            out = out + np.where(np.asarray(airborne, bool)[:, None], t, 0.0)
        else:
            t[:] = 0.0
        return out
