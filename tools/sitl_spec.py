"""What world a test asks for: the ``@pytest.mark.towerlink(...)`` marker and the run's
``--towerlink-*`` options, checked and merged into one :class:`SitlSpec` (pure: no sockets,
no files; the runners turn it into a world).

    @pytest.mark.towerlink(drones=1, rovers=0, speedup="max", params={"FS_GCS_ENABLE": 1},
                           mission="survey.waypoints", wind="5,270", seed=3,
                           home=(-35.36, 149.16, 584), lockstep=False, subprocess=False)

Every keyword is optional. ``params`` are ArduPilot parameter defaults given to every vehicle
(as ``towerlink sitl --params``); ``mission`` is a QGC WPL 110 file loaded into vehicle 0's
mission at start, or ``{vehicle index: file}``; ``wind`` is ``"SPD,DIR[,TURB]"`` (m/s, the
direction it comes FROM in degrees, m/s) or a tuple of those numbers; ``home`` is the world
origin (lat deg, lon deg, alt m AMSL) or ``"LAT,LON,ALT"``.

The run's options: ``--towerlink-speedup N|max`` overrides every test's speedup (run the suite
at 1 to watch it, or at 2 to show a lockstep test does not care), ``--towerlink-mode
thread|subprocess`` overrides where the worlds run, ``--towerlink-keep-logs`` keeps the tlog
and track plot of passing tests too.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from common.mavlink.lockstep import speedup_arg, speedup_text
from vehicle.physics.wind import WindParams, parse_wind, wind_from_values
from vehicle.world import DEFAULT_HOME

MARKER = "towerlink"
MARKER_HELP = ("towerlink(drones=1, rovers=0, speedup='max', params={}, mission=None, wind=None, seed=0, "
               "home=None, lockstep=False, subprocess=False): the world the towerlink_sitl fixture starts")
KEYWORDS = ("drones", "rovers", "speedup", "params", "mission", "wind", "seed", "home", "lockstep",
            "subprocess")


class SpecError(ValueError):
    """A marker keyword or option the fixture cannot use; the message names it."""


@dataclass(frozen=True)
class SitlSpec:
    """One test's world. speedup: sim s per wall s (inf: as fast as the CPU allows);
    params: ArduPilot parameter defaults of every vehicle; missions: vehicle index -> QGC WPL
    file; home: world origin (lat deg, lon deg, alt m AMSL); lockstep: the world waits at every
    TICK for one gcs.client participant (the test's ``sitl.client(i)``)."""
    drones: int = 1
    rovers: int = 0
    speedup: float = math.inf
    params: Mapping[str, float] = field(default_factory=dict)
    missions: Mapping[int, Path] = field(default_factory=dict)
    wind: WindParams | None = None
    wind_text: str | None = None           # as `towerlink sitl --wind` spells it
    seed: int = 0
    home: tuple[float, float, float] = DEFAULT_HOME
    lockstep: bool = False
    subprocess: bool = False
    keep_logs: bool = False

    @property
    def count(self) -> int:
        return self.drones + self.rovers

    @property
    def speedup_text(self) -> str:
        return speedup_text(self.speedup)

    def marker_kwargs(self) -> dict[str, Any]:
        """The marker keywords that make this spec again (JSON-able: the process world's)."""
        return {"drones": self.drones, "rovers": self.rovers, "speedup": self.speedup_text,
                "params": dict(self.params), "mission": {i: str(p) for i, p in self.missions.items()},
                "wind": self.wind_text, "seed": self.seed, "home": list(self.home), "lockstep": self.lockstep,
                "subprocess": self.subprocess}


def _speedup(value: Any) -> float:
    try:
        return speedup_arg(str(value))
    except ValueError as exc:
        raise SpecError(f"towerlink marker: {exc}") from None


def _wind(value: Any) -> tuple[WindParams | None, str | None]:
    if value is None:
        return None, None
    try:
        if isinstance(value, str):
            return parse_wind(value), value
        vals = [float(v) for v in value]
        return wind_from_values(*vals), ",".join(f"{v:g}" for v in vals)
    except (TypeError, ValueError) as exc:
        raise SpecError(f"towerlink marker: wind={value!r}: {exc}") from None


def _home(value: Any) -> tuple[float, float, float]:
    if value is None:
        return DEFAULT_HOME
    parts = value.split(",") if isinstance(value, str) else value
    try:
        lat, lon, alt = (float(p) for p in parts)
    except (TypeError, ValueError):
        raise SpecError(f"towerlink marker: home={value!r}: expected (lat, lon, alt)") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise SpecError(f"towerlink marker: home={value!r}: latitude/longitude out of range")
    return lat, lon, alt


def _missions(value: Any, count: int) -> dict[int, Path]:
    if value is None:
        return {}
    pairs = value.items() if isinstance(value, Mapping) else [(0, value)]   # JSON keys are text
    out = {}
    for i, path in pairs:
        if not 0 <= int(i) < count:
            raise SpecError(f"towerlink marker: mission for vehicle {i}, but the world has {count}")
        if not Path(path).is_file():
            raise SpecError(f"towerlink marker: mission file {path} not found")
        out[int(i)] = Path(path)
    return out


def _params(value: Any) -> dict[str, float]:
    if value is None:
        return {}
    try:
        return {str(k).upper(): float(v) for k, v in dict(value).items()}
    except (TypeError, ValueError) as exc:
        raise SpecError(f"towerlink marker: params must map names to numbers: {exc}") from None


def make_spec(marker_kwargs: Mapping[str, Any], *, speedup: str | None = None, mode: str | None = None,
              keep_logs: bool = False) -> SitlSpec:
    """The spec from a test's marker keywords and the run's options (an option, when given,
    wins over the marker). Raises SpecError naming an unknown or bad keyword."""
    unknown = sorted(set(marker_kwargs) - set(KEYWORDS))
    if unknown:
        raise SpecError(f"towerlink marker: unknown keyword(s) {', '.join(unknown)}; "
                        f"known: {', '.join(KEYWORDS)}")
    kw = dict(marker_kwargs)
    drones, rovers = int(kw.get("drones", 1)), int(kw.get("rovers", 0))
    if drones < 0 or rovers < 0 or drones + rovers == 0:
        raise SpecError("towerlink marker: the world needs at least one vehicle")
    wind, wind_text = _wind(kw.get("wind"))
    subprocess = bool(kw.get("subprocess", False)) if mode is None else mode == "subprocess"
    lockstep = bool(kw.get("lockstep", False))
    return SitlSpec(drones=drones, rovers=rovers,
                    speedup=_speedup(speedup if speedup is not None else kw.get("speedup", "max")),
                    params=_params(kw.get("params")), missions=_missions(kw.get("mission"), drones + rovers),
                    wind=wind, wind_text=wind_text, seed=int(kw.get("seed", 0)), home=_home(kw.get("home")),
                    lockstep=lockstep, subprocess=subprocess, keep_logs=keep_logs)


def parm_text(params: Mapping[str, float]) -> str:
    """Parameters as an ArduPilot .parm file ("NAME VALUE" lines)."""
    return "".join(f"{k} {v:.9g}\n" for k, v in sorted(params.items()))
