"""The client corpus's manifest (examples/clients/corpus.toml): one entry per client program,
with how to run it and what it does against ArduPilot SITL (pure: reads a file, no sockets).

Each ``[[program]]`` has: ``name``; ``file`` (relative to the manifest); ``kind`` (``pymavlink``
and ``autotest``: the main venv's Python; ``mavsdk4``: the same, MAVSDK 4.x's native API;
``mavsdk3``: MAVSDK-Python 3.x's interpreter; ``mavproxy``: a typed-command script played into
MAVProxy); ``source`` (the public program or helper it is written after); ``ardupilot`` (what
it does against ArduPilot SITL, and where that comes from); ``checks`` (tools.client_corpus_checks);
optional ``speedup`` (default 1: the program waits on wall-clock time), ``timeout`` (wall s,
default 120), ``settle`` (wall s to wait for ``disarmed`` after the program ends, default 60),
``exit`` (the exit status wanted, default 0; -1: any, or none at the timeout), ``args`` (its arguments, with {tcp},
{udp}, {out}, {grpc} and {file} replaced), ``sitl`` (extra `towerlink sitl` arguments).
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

KINDS = ("pymavlink", "autotest", "mavsdk4", "mavsdk3", "mavproxy")

#: how each kind is told where the vehicle is, unless the entry gives `args`
DEFAULT_ARGS = {
    "pymavlink": ["tcp:127.0.0.1:{tcp}"],
    "autotest": ["tcp:127.0.0.1:{tcp}"],
    "mavsdk4": ["udpin://127.0.0.1:{out}"],
    "mavsdk3": ["udpin://0.0.0.0:{out}", "{grpc}"],
    "mavproxy": ["{file}", "{tcp}"],
}


@dataclass(frozen=True)
class Program:
    """One client program of the corpus and its expectation."""

    name: str
    path: Path
    kind: str
    source: str
    ardupilot: str
    checks: tuple[str, ...]
    speedup: float = 1.0
    timeout: float = 120.0
    settle: float = 60.0
    exit: int | None = 0
    args: tuple[str, ...] = ()
    sitl: tuple[str, ...] = ()

    @property
    def group(self) -> str:
        return self.path.parent.name

    def argv(self, ports: dict[str, int]) -> list[str]:
        """The program's arguments with the run's ports (and its own path) filled in."""
        subst = {k: str(v) for k, v in ports.items()} | {"file": str(self.path)}
        return [a.format(**subst) for a in (self.args or DEFAULT_ARGS[self.kind])]


@dataclass
class Corpus:
    programs: list[Program] = field(default_factory=list)

    def select(self, pattern: str | None) -> list[Program]:
        import re
        return [p for p in self.programs if not pattern or re.search(pattern, p.name)]


def load(manifest: Path) -> Corpus:
    """Read and check the manifest: every file exists, kinds and names are known and unique."""
    data = tomllib.loads(manifest.read_text())
    out: list[Program] = []
    for raw in data.get("program", []):
        kind = raw["kind"]
        if kind not in KINDS:
            raise ValueError(f"{raw['name']}: unknown kind {kind!r}")
        path = (manifest.parent / raw["file"]).resolve()
        if not path.exists():
            raise ValueError(f"{raw['name']}: no file {path}")
        want = raw.get("exit", 0)
        out.append(Program(
            name=raw["name"], path=path, kind=kind, source=raw["source"], ardupilot=raw["ardupilot"],
            checks=tuple(raw.get("checks", ())), speedup=float(raw.get("speedup", 1.0)),
            timeout=float(raw.get("timeout", 120.0)), settle=float(raw.get("settle", 60.0)),
            exit=None if want == -1 else int(want), args=tuple(raw.get("args", ())),
            sitl=tuple(raw.get("sitl", ()))))
    names = [p.name for p in out]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ValueError(f"names used twice: {sorted(dup)}")
    return Corpus(out)
