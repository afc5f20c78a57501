"""Which package may import which (docs/ARCHITECTURE.md, "Rooms and who imports whom").

Every import in the tree is read with ast (module level and inside functions alike, since a
lazy import is still a dependency), relative imports resolved, and checked against the rules:

- gcs/ is the foundation: it never imports bridge/, vehicle/ or tools/.
- vehicle/ imports only gcs's pure libraries (frames, geo, modes, mavstr, endpoints, wpl, signing), never
  bridge/, tools/, or gcs's programs (gcs.client, gcs.tower, ...).
- bridge/ never imports vehicle/, tools/, gcs.client or gcs.tower.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

# gcs modules the simulated vehicle may use: pure libraries, no sockets of their own.
VEHICLE_MAY_USE = ("gcs.frames", "gcs.geo", "gcs.modes", "gcs.mavstr", "gcs.endpoints", "gcs.wpl", "gcs.peers",
                   "gcs.lockstep", "gcs.collector",
                   "gcs.signing")
GCS_PROGRAMS = ("gcs.client", "gcs.tower", "gcs.tower_family", "gcs.tower_link")


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports_of(path: Path, root: Path = ROOT) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import statement in one file under root."""
    tree = ast.parse(path.read_text(), filename=str(path))
    here = _module_name(path, root)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            # `from gcs import client` imports gcs.client: name the submodule when it is one
            for a in node.names:
                sub = f"{mod}.{a.name}"
                where = root / Path(*sub.split("."))
                is_pkg_member = where.with_suffix(".py").exists() or where.is_dir()
                out.append((node.lineno, sub if is_pkg_member else mod))
    return out


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def violations(package: str) -> list[str]:
    bad = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for line, name in imports_of(path):
            why = rule_broken(package, name)
            if why:
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {name}: {why}")
    return bad


def rule_broken(package: str, name: str) -> str | None:
    """Why `package` may not import `name`, or None when it may."""
    if package == "gcs":
        if _within(name, ("bridge", "vehicle", "tools", "tests")):
            return "gcs is the foundation every package stands on"
    elif package == "vehicle":
        if _within(name, ("bridge", "tools", "tests")):
            return "the simulated vehicle must not depend on the bridge or the tools"
        if _within(name, ("gcs",)) and not _within(name, VEHICLE_MAY_USE):
            return f"the vehicle may use only gcs's pure libraries {VEHICLE_MAY_USE}"
    elif package == "bridge":
        if _within(name, ("vehicle", "tools", "tests") + GCS_PROGRAMS):
            return "the bridge talks to vehicles and GCSs over MAVLink, never by import"
    return None


@pytest.mark.parametrize("package", ["gcs", "vehicle", "bridge"])
def test_package_imports_follow_the_rules(package):
    assert violations(package) == []


def test_imports_of_resolves_relative_and_lazy_imports(tmp_path):
    """The checker itself: a lazy import inside a function and a relative import both count."""
    pkg = tmp_path / "vehicle" / "link"
    pkg.mkdir(parents=True)
    (tmp_path / "vehicle" / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (tmp_path / "vehicle" / "fleet.py").write_text("")
    f = pkg / "x.py"
    f.write_text("from ..fleet import Setpoint\n"
                 "def go():\n    from bridge.router import Bridge\n    import gcs.tower\n")
    names = [n for _, n in imports_of(f, tmp_path)]
    assert names == ["vehicle.fleet", "bridge.router", "gcs.tower"]
    assert rule_broken("vehicle", "bridge.router")
    assert rule_broken("vehicle", "gcs.tower")
    assert rule_broken("vehicle", "gcs.client")
    assert rule_broken("vehicle", "vehicle.fleet") is None
    assert rule_broken("vehicle", "gcs.frames.transform") is None
    assert rule_broken("gcs", "bridge.follow")
    assert rule_broken("bridge", "vehicle.fleet")
    assert rule_broken("bridge", "gcs.frames") is None
