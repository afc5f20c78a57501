"""Sweep plans: factors, their values, the grid, run ids (pure: no Ray, no sockets, no clock).

A sweep is a list of runs; a run is one value for each factor. Factors:

  seed          int >= 0                    the world's noise seed (fly --seed)
  wind          SPEED | [SPEED, DIR(, TURB)] | {speed, direction, turbulence}
                                            the scenario's wind (m/s, deg it comes FROM, m/s);
                                            a bare speed keeps the scenario's direction (else 270)
  tower_loss    0 <= x < 1                  fraction of the tower link's packets dropped (fly --tower-loss)
  tower_link.S  number                      a tower-link setting for the whole run (fly --tower-link S=V):
                                            loss, latency, jitter, reorder, duplicate, bandwidth, each
                                            also as tower_link.up.S / tower_link.down.S
  follow_frame  drone | drone_yaw           the frame the rover's goal is written in (fly --follow-frame)
  finish        land | rtl | none           after the goals (fly --finish)
  NAME          number                      a vehicle parameter by its ArduPilot name, e.g. WPNAV_SPEED
                                            (cm/s); checked against the parameter table (fly --param)
  a.b.c         any TOML value              a scenario value by its dotted key, e.g. mission.altitude;
                                            the key must exist in the scenario (the run flies a copy);
                                            a list's item by its index: faults.0.t, faults.1.SIM_BATT_VOLTAGE

A sweep file (TOML) gives a grid (the cartesian product of its lists) and/or an explicit list
of runs; each explicit run is crossed with the grid::

    scenario = "default"          # optional; the command line's SCENARIO wins
    seeds = "1-3"                 # or [1, 2, 3]: the seed factor
    timeout = 300                 # optional: wall seconds per run
    [grid]
    follow_frame = ["drone", "drone_yaw"]
    tower_loss = [0.0, 0.2]
    [[runs]]
    WPNAV_SPEED = 300
    [[runs]]
    WPNAV_SPEED = 800
    "mission.altitude" = 12.0

On the command line `--set FACTOR=V1,V2,...` adds (or replaces) a grid factor; values are TOML
values (`--set wind=0,[8,270,1]`), a bare word is a string. Everything is checked before any
run starts; errors are SweepError with a message that says what and where.
"""
from __future__ import annotations

import difflib
import hashlib
import itertools
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping

from tools.vehicle_params import param_table

NAMED_FACTORS = ("seed", "wind", "tower_loss", "follow_frame", "finish")
FOLLOW_FRAMES = ("drone", "drone_yaw")
FINISH = ("land", "rtl", "none")
PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")       # ArduPilot: at most 16 characters
SCENARIO_KEY = re.compile(r"^[a-z_][a-z0-9_]*(\.([a-z_][a-z0-9_]*|[0-9]+|[A-Z][A-Z0-9_]*))*$")
LINK_PREFIX = "tower_link."
DEFAULT_WIND_DIRECTION = 270.0


class SweepError(ValueError):
    """A sweep plan that cannot run: unknown factor, bad value, bad file. Says what and where."""


@dataclass(frozen=True)
class Run:
    """One run of a sweep: a value per factor (in the plan's factor order) and its stable id."""
    factors: dict[str, Any]
    run_id: str

    def label(self) -> str:
        return " ".join(f"{k}={format_value(v)}" for k, v in self.factors.items())


@dataclass
class Plan:
    """What to sweep: the grid (factor -> values), explicit runs, and the per-run options."""
    grid: dict[str, list[Any]] = field(default_factory=dict)
    runs: list[dict[str, Any]] = field(default_factory=list)
    scenario: str | None = None
    timeout: float | None = None         # wall seconds per run
    goal_timeout: float | None = None    # wall seconds per goal (fly --goal-timeout)


# ----------------------------------------------------------------------------- values


def format_value(v: Any) -> str:
    """A factor value as a short text (table cells, labels): 0.2, drone, [8,270,1]."""
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple, dict)):
        return json.dumps(v, separators=(",", ":"))
    return str(v)


def split_values(text: str) -> list[str]:
    """'a,b,[1,2],"x,y"' -> ['a', 'b', '[1,2]', '"x,y"']: commas inside [] {} or quotes do not split."""
    out, depth, quote, cur = [], 0, None, []
    for ch in text:
        if quote:
            cur.append(ch)
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
            cur.append(ch)
        elif ch in "[{":
            depth += 1
            cur.append(ch)
        elif ch in "]}":
            depth -= 1
            cur.append(ch)
        elif ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    if quote or depth:
        raise SweepError(f"unbalanced quotes or brackets in {text!r}")
    out.append("".join(cur).strip())
    if any(v == "" for v in out):
        raise SweepError(f"an empty value in {text!r}")
    return out


def parse_value(text: str) -> Any:
    """A command-line value: a TOML value (1, 0.2, true, [8,270,1], "x"), else the bare string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_seeds(spec: str | int | Iterable[int]) -> list[int]:
    """'1-20' / '1,3,5' / '1-3,10' / 4 / [1, 2] -> a list of seeds (order kept, no repeats)."""
    if isinstance(spec, bool):
        raise SweepError(f"seeds: {spec!r} is not a seed list (e.g. 1-20 or 1,3,5)")
    if isinstance(spec, int):
        items: list[int] = [spec]
    elif isinstance(spec, str):
        items = []
        for part in spec.split(","):
            m = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?", part)
            if not m:
                raise SweepError(f"seeds: {part.strip()!r} is not a seed or a range (e.g. 1-20 or 1,3,5)")
            lo = int(m.group(1))
            hi = int(m.group(2)) if m.group(2) is not None else lo
            if hi < lo:
                raise SweepError(f"seeds: range {lo}-{hi} runs backwards")
            if hi - lo >= 100_000:
                raise SweepError(f"seeds: range {lo}-{hi} is too long")
            items.extend(range(lo, hi + 1))
    else:
        items = [check_value("seed", s, {}) for s in spec]
    return list(dict.fromkeys(items))


# ----------------------------------------------------------------------------- factors


def factor_kind(name: str, scenario_data: Mapping[str, Any]) -> str:
    """'named', 'link', 'param' or 'scenario'; SweepError for a name that is none of them."""
    if name in NAMED_FACTORS:
        return "named"
    if name.startswith(LINK_PREFIX):
        return "link"
    if PARAM_NAME.match(name):
        return "param"
    if SCENARIO_KEY.match(name):
        if _has_key(scenario_data, name):
            return "scenario"
        keys = list(NAMED_FACTORS) + list(_dotted_keys(scenario_data))
        close = difflib.get_close_matches(name, keys, n=1)
        hint = f" (did you mean {close[0]}?)" if close else ""
        raise SweepError(f"unknown factor {name!r}{hint}: not one of {', '.join(NAMED_FACTORS)}, "
                         f"a tower-link setting ({LINK_PREFIX}latency), a parameter (UPPER_CASE, e.g. WPNAV_SPEED) "
                         f"or a key of the scenario (e.g. mission.altitude)")
    raise SweepError(f"unknown factor {name!r}: factors are {', '.join(NAMED_FACTORS)}, a tower-link setting "
                     f"({LINK_PREFIX}latency), a parameter name (e.g. WPNAV_SPEED) or a dotted scenario key "
                     f"(e.g. mission.altitude)")


def _child(node: Any, part: str) -> tuple[bool, Any]:
    """(found, value) of a table's key or a list's index (a dotted key's one step)."""
    if isinstance(node, Mapping):
        return (part in node, node.get(part))
    if isinstance(node, list) and part.isdigit() and int(part) < len(node):
        return (True, node[int(part)])
    return (False, None)


def _has_key(data: Mapping[str, Any], dotted: str) -> bool:
    node: Any = data
    for part in dotted.split("."):
        found, node = _child(node, part)
        if not found:
            return False
    return True


def _dotted_keys(data: Any, prefix: str = "") -> Iterable[str]:
    items = data.items() if isinstance(data, Mapping) else ((str(i), v) for i, v in enumerate(data))
    for k, v in items:
        yield prefix + k
        if isinstance(v, (Mapping, list)):
            yield from _dotted_keys(v, prefix + k + ".")


def _number(name: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise SweepError(f"{name}: {format_value(v)!r} is not a finite number")
    return float(v)


def check_value(name: str, v: Any, scenario_data: Mapping[str, Any],
                params: Mapping[str, Any] | None = None) -> Any:
    """The value of factor `name` in its canonical type; SweepError if it is not a valid one."""
    kind = factor_kind(name, scenario_data)
    if kind == "param":
        table = params if params is not None else param_table()
        d = table.get(name)
        if d is None:
            close = difflib.get_close_matches(name, list(table), n=1)
            hint = f" (did you mean {close[0]}?)" if close else ""
            raise SweepError(f"unknown parameter {name!r}{hint}")
        x = _number(name, v)
        if not d.lo <= x <= d.hi:
            raise SweepError(f"{name}: {x:g} is outside its range {d.lo:g}..{d.hi:g}")
        if d.integer:
            if x != int(x):
                raise SweepError(f"{name}: {x:g} must be a whole number")
            return int(x)
        return x
    if kind == "link":
        from common.link_settings import check_setting, split_key
        try:
            split_key(name[len(LINK_PREFIX):])
            return check_setting(name.rpartition(".")[2], _number(name, v))
        except ValueError as exc:
            raise SweepError(f"{name}: {exc}") from None
    if kind == "scenario":
        if isinstance(v, float) and not math.isfinite(v):
            raise SweepError(f"{name}: {v!r} is not a finite number")
        return v
    if name == "seed":
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int) or v < 0 or v >= 2 ** 32:
            raise SweepError(f"seed: {format_value(v)!r} is not a whole number in 0..2^32-1")
        return v
    if name == "tower_loss":
        x = _number(name, v)
        if not 0.0 <= x < 1.0:
            raise SweepError(f"tower_loss: {x:g} is outside 0 <= loss < 1 (a fraction of packets)")
        return x
    if name == "follow_frame":
        if v not in FOLLOW_FRAMES:
            raise SweepError(f"follow_frame: {format_value(v)!r} is not one of {', '.join(FOLLOW_FRAMES)}")
        return v
    if name == "finish":
        if v not in FINISH:
            raise SweepError(f"finish: {format_value(v)!r} is not one of {', '.join(FINISH)}")
        return v
    return wind_value(v, scenario_data)


def wind_value(v: Any, scenario_data: Mapping[str, Any]) -> list[float]:
    """[speed m/s, from-direction deg, turbulence m/s] from a speed, a list or a table."""
    base = scenario_data.get("wind") if isinstance(scenario_data.get("wind"), Mapping) else {}
    if isinstance(v, Mapping):
        if set(v) - {"speed", "direction", "turbulence"} or "speed" not in v:
            raise SweepError(f"wind: {format_value(v)} must have speed (and direction, turbulence) only")
        parts = [v["speed"], v.get("direction", base.get("direction", DEFAULT_WIND_DIRECTION)),
                 v.get("turbulence", base.get("turbulence", 0.0))]
    elif isinstance(v, (list, tuple)):
        if not 1 <= len(v) <= 3:
            raise SweepError(f"wind: {format_value(v)} must be [speed, direction(, turbulence)]")
        parts = list(v) + [base.get("direction", DEFAULT_WIND_DIRECTION), base.get("turbulence", 0.0)][len(v) - 1:]
    else:
        parts = [v, base.get("direction", DEFAULT_WIND_DIRECTION), base.get("turbulence", 0.0)]
    s, d, t = (_number("wind", p) for p in parts)
    if not 0.0 <= s <= 40.0:
        raise SweepError(f"wind: speed {s:g} m/s is outside 0..40 (SIM_WIND_SPD)")
    if not 0.0 <= d <= 360.0:
        raise SweepError(f"wind: direction {d:g} deg is outside 0..360 (where the wind comes from)")
    if not 0.0 <= t <= 10.0:
        raise SweepError(f"wind: turbulence {t:g} m/s is outside 0..10 (SIM_WIND_TURB)")
    return [s, d, t]


# ----------------------------------------------------------------------------- plans


def plan_from_toml(text: str, where: str = "sweep file") -> Plan:
    """A Plan from a sweep file's text; SweepError for bad TOML or keys it does not know."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{where}: not valid TOML: {exc}") from None
    unknown = set(data) - {"scenario", "seeds", "timeout", "goal_timeout", "grid", "runs"}
    if unknown:
        raise SweepError(f"{where}: unknown key(s) {', '.join(sorted(unknown))} "
                         "(known: scenario, seeds, timeout, goal_timeout, [grid], [[runs]])")
    plan = Plan()
    if "scenario" in data:
        if not isinstance(data["scenario"], str):
            raise SweepError(f"{where}: scenario must be a file path or a shipped scenario's name")
        plan.scenario = data["scenario"]
    for key in ("timeout", "goal_timeout"):
        if key in data:
            x = _number(f"{where}: {key}", data[key])
            if x <= 0:
                raise SweepError(f"{where}: {key} must be > 0 seconds")
            setattr(plan, key, x)
    grid = data.get("grid", {})
    if not isinstance(grid, dict):
        raise SweepError(f"{where}: [grid] must be a table of factor = [values]")
    for name, values in grid.items():
        # a list is the factor's values (wind = [0, 4, 8]: three speeds; [[8, 270, 1]]: one wind)
        values = values if isinstance(values, list) else [values]
        if not values:
            raise SweepError(f"{where}: grid factor {name!r} has no values")
        plan.grid[name] = values
    if "seeds" in data:
        plan.grid["seed"] = parse_seeds(data["seeds"])
    runs = data.get("runs", [])
    if not isinstance(runs, list) or not all(isinstance(r, dict) for r in runs):
        raise SweepError(f"{where}: runs must be an array of tables ([[runs]] factor = value ...)")
    plan.runs = [dict(r) for r in runs]
    return plan


def apply_cli(plan: Plan, sets: Iterable[str] = (), seeds: str | None = None) -> Plan:
    """`--set FACTOR=V1,V2` and `--seeds SPEC` over a plan (they replace the file's factor)."""
    for item in sets:
        name, eq, text = item.partition("=")
        name = name.strip()
        if not eq or not name or not text.strip():
            raise SweepError(f"--set {item!r}: write FACTOR=V1,V2,... (e.g. tower_loss=0,0.2)")
        plan.grid[name] = [parse_value(t) for t in split_values(text)]
    if seeds is not None:
        plan.grid["seed"] = parse_seeds(seeds)
    return plan


def run_id(factors: Mapping[str, Any], scenario_digest: str = "") -> str:
    """A stable id for a run: a hash of the scenario and the factors (order does not matter)."""
    blob = json.dumps({"scenario": scenario_digest, "factors": dict(sorted(factors.items()))},
                      sort_keys=True, separators=(",", ":"))
    return "r" + hashlib.sha256(blob.encode()).hexdigest()[:11]


def expand(plan: Plan, scenario_data: Mapping[str, Any], scenario_digest: str = "",
           params: Mapping[str, Any] | None = None,
           validate_scenario: Callable[[dict], None] | None = None) -> list[Run]:
    """Every run of the plan, checked: explicit runs crossed with the grid's product.

    Seed 1 when no factor names a seed. Repeated runs (same factors) are kept once.
    `validate_scenario(data)` is called for each distinct scenario copy a run would fly.
    """
    params = params if params is not None else (
        param_table() if any(PARAM_NAME.match(n) for n in _all_names(plan)) else {})
    grid = {name: [check_value(name, v, scenario_data, params) for v in values]
            for name, values in plan.grid.items()}
    explicit = [{name: check_value(name, v, scenario_data, params) for name, v in r.items()}
                for r in plan.runs] or [{}]
    for k, r in enumerate(plan.runs):
        both = sorted(set(r) & set(grid))
        if both:
            raise SweepError(f"runs[{k}] sets {', '.join(both)}, which the grid also sweeps")
    if not any("seed" in r for r in explicit) and "seed" not in grid:
        grid["seed"] = [1]
    names = list(grid)
    out: dict[str, Run] = {}
    checked: set[str] = set()
    for r in explicit:
        for combo in itertools.product(*(grid[n] for n in names)):
            factors = {**r, **dict(zip(names, combo))}
            rid = run_id(factors, scenario_digest)
            if rid in out:
                continue
            if validate_scenario is not None:
                data = scenario_copy(scenario_data, factors)
                key = json.dumps(data, sort_keys=True, default=str)
                if data is not None and key not in checked:
                    checked.add(key)
                    try:
                        validate_scenario(data)
                    except ValueError as exc:
                        raise SweepError(f"run {format_factors(factors)}: {exc}") from None
            out[rid] = Run(factors, rid)
    return list(out.values())


def _all_names(plan: Plan) -> set[str]:
    return set(plan.grid) | {n for r in plan.runs for n in r}


def format_factors(factors: Mapping[str, Any]) -> str:
    return " ".join(f"{k}={format_value(v)}" for k, v in factors.items())


def varying_factors(runs: list[Run]) -> list[str]:
    """Factors that take more than one value across the runs (in first-seen order)."""
    seen: dict[str, set[str]] = {}
    for r in runs:
        for k, v in r.factors.items():
            seen.setdefault(k, set()).add(format_value(v))
    return [k for k, vals in seen.items() if len(vals) > 1]


# ----------------------------------------------------------------------------- one run's command


def scenario_copy(scenario_data: Mapping[str, Any], factors: Mapping[str, Any]) -> dict | None:
    """The scenario a run flies when it sets wind or scenario keys (a deep copy); None if unchanged."""
    changes = {k: v for k, v in factors.items() if k == "wind" or (
        k not in NAMED_FACTORS and not PARAM_NAME.match(k) and not k.startswith(LINK_PREFIX))}
    if not changes:
        return None
    data = json.loads(json.dumps(scenario_data))
    for k, v in changes.items():
        if k == "wind":
            data["wind"] = {"speed": v[0], "direction": v[1], "turbulence": v[2]}
            continue
        *path, last = k.split(".")
        node = data
        for p in path:
            node = node[int(p)] if isinstance(node, list) else node[p]
        if isinstance(node, list):
            node[int(last)] = v
        else:
            node[last] = v
    return data


def fly_args(factors: Mapping[str, Any], scenario: str | None, run_dir: str, *,
             timeout: float, goal_timeout: float | None = None) -> list[str]:
    """`towerlink fly` arguments for one run (lockstep, speedup max, quiet, no helper children: the
    sweep's other runs use the other cores); `scenario` is the file the run flies (its own copy
    when it changes scenario values)."""
    args = ["fly", *([scenario] if scenario else []), "--lockstep", "--speedup", "max", "--quiet",
            "--seed", str(factors.get("seed", 1)), "--out", run_dir, "--timeout", f"{timeout:g}"]
    if goal_timeout is not None:
        args += ["--goal-timeout", f"{goal_timeout:g}"]
    if "tower_loss" in factors:
        args += ["--tower-loss", f"{factors['tower_loss']:g}"]
    if "follow_frame" in factors:
        args += ["--follow-frame", factors["follow_frame"]]
    if "finish" in factors:
        args += ["--finish", factors["finish"]]
    link = [f"{k[len(LINK_PREFIX):]}={v:g}" for k, v in factors.items() if k.startswith(LINK_PREFIX)]
    if link:
        args += ["--tower-link", ",".join(link)]
    for k, v in factors.items():
        if PARAM_NAME.match(k):
            args += ["--param", f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"]
    return [*args, "--no-helpers"]


# ----------------------------------------------------------------------------- TOML out


_BARE = re.compile(r"[A-Za-z0-9_-]+")


def to_toml(data: Mapping[str, Any]) -> str:
    """A TOML document for plain data (tables, arrays, str, int, float, bool): one `key = value`
    line per top-level key, tables inline. tomllib.loads(to_toml(d)) == d."""
    return "".join(f"{_key(k)} = {_toml_value(v)}\n" for k, v in data.items())


def _key(k: str) -> str:
    return k if _BARE.fullmatch(k) else _toml_str(k)    # fullmatch: "$" also matches before a final "\n"


def _toml_str(s: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped, the rest as is."""
    out = []
    for ch in s:
        if ch in '"\\':
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, Mapping):
        return "{" + ", ".join(f"{_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} as TOML")


def scenario_digest(path: Path) -> str:
    """A short hash of a scenario file's bytes: run ids change when the scenario does."""
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]
