"""The house's structure (docs/ARCHITECTURE.md, "Rooms and who imports whom"), enforced.

Every import in the tree is read with ast (module level and inside functions alike, since a
lazy import is still a dependency), relative imports resolved, and checked against:

- the rooms' rules: common/ is the foundation and imports no other room; vehicle/, bridge/
  and gcs/ import common/ and never each other (they talk over MAVLink); the vehicle may not
  use the generated dialect or the tf2_ros node API; tools/ may import everything;
- no import cycle between modules, lazy imports included;
- no class over 300 lines.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("common", "vehicle", "gcs", "bridge", "tools")
MAX_CLASS_LINES = 300

# common modules the simulated vehicle may not use: the generated dialect (it speaks
# ArduPilot's messages only; lockstep is packed by hand in common.mavlink.lockstep) and the
# tf2_ros node API (the bridge's and the students' nodes).
VEHICLE_MAY_NOT_USE = ("common.mavlink.dialect", "common.tf2_ros")
ROOMS = ("common", "vehicle", "gcs", "bridge", "tools", "tests")


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
            # `from common import geo` imports common.geo: name the submodule when it is one
            for a in node.names:
                sub = f"{mod}.{a.name}"
                where = root / Path(*sub.split("."))
                is_pkg_member = where.with_suffix(".py").exists() or where.is_dir()
                out.append((node.lineno, sub if is_pkg_member else mod))
    return out


def _within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def project_files(root: Path = ROOT, packages=PACKAGES) -> list[Path]:
    return [p for pkg in packages for p in sorted((root / pkg).rglob("*.py"))]


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
    others = {"common": ("vehicle", "gcs", "bridge", "tools", "tests"),
              "vehicle": ("gcs", "bridge", "tools", "tests"),
              "bridge": ("vehicle", "gcs", "tools", "tests"),
              "gcs": ("vehicle", "bridge", "tools", "tests")}.get(package, ())
    if _within(name, others):
        if package == "common":
            return "common is the foundation every room stands on; it imports none of them"
        return f"{package} talks to the other rooms over MAVLink, never by import"
    if package == "vehicle" and _within(name, VEHICLE_MAY_NOT_USE):
        return f"the simulated vehicle may not use {VEHICLE_MAY_NOT_USE}"
    return None


def import_graph(root: Path = ROOT, packages=PACKAGES) -> dict[str, set[str]]:
    """module -> the project modules it imports (lazy imports included). A package's
    ``__init__`` is the module named like the package."""
    files = project_files(root, packages)
    known = {_module_name(p, root) for p in files}
    graph: dict[str, set[str]] = {}
    for p in files:
        me = _module_name(p, root)
        deps = set()
        for _, name in imports_of(p, root):
            # importing a.b.c runs a, a.b and a.b.c; the parents' __init__ are the
            # ones that can close a cycle, and they are edges only when they hold code
            while name and name not in known:
                name = name.rpartition(".")[0]
            if name and name != me:
                deps.add(name)
        graph[me] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        # iterative DFS: the graph is a few hundred modules, but recursion depth is not ours to spend
        work = [(v, iter(sorted(graph.get(v, ()))))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == node:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def long_classes(root: Path = ROOT, packages=PACKAGES + ("tests", "examples"),
                 limit: int = MAX_CLASS_LINES) -> list[str]:
    """'path:line Class (N lines)' for every class longer than `limit` lines."""
    out = []
    for pkg in packages:
        for p in sorted((root / pkg).rglob("*.py")):
            for node in ast.walk(ast.parse(p.read_text(), filename=str(p))):
                if isinstance(node, ast.ClassDef):
                    n = node.end_lineno - node.lineno + 1
                    if n > limit:
                        out.append(f"{p.relative_to(root)}:{node.lineno} {node.name} ({n} lines)")
    return out


@pytest.mark.parametrize("package", ["common", "vehicle", "gcs", "bridge"])
def test_package_imports_follow_the_rules(package):
    assert violations(package) == []


def test_no_import_cycles_lazy_or_not():
    assert cycles(import_graph()) == []


def test_no_class_over_300_lines():
    assert long_classes() == []


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
    assert rule_broken("vehicle", "common.mavlink.dialect")
    assert rule_broken("vehicle", "vehicle.fleet") is None
    assert rule_broken("vehicle", "common.frames.transform") is None
    assert rule_broken("common", "bridge.follow")
    assert rule_broken("bridge", "vehicle.fleet")
    assert rule_broken("bridge", "gcs.client")
    assert rule_broken("bridge", "common.frames") is None
    assert rule_broken("tools", "vehicle.fleet") is None


def test_the_cycle_finder_sees_a_lazy_cycle_and_the_class_rule_counts_lines(tmp_path):
    """The checkers themselves: a cycle closed by an import inside a function is found, a
    one-way chain is not; a 301-line class is reported and a 300-line one is not."""
    pkg = tmp_path / "tools"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from tools import b\n")
    (pkg / "b.py").write_text("def late():\n    from tools.a import x\n")
    (pkg / "c.py").write_text("import tools.b\n")
    assert cycles(import_graph(tmp_path, ("tools",))) == [["tools.a", "tools.b"]]
    (pkg / "b.py").write_text("x = 1\n")
    assert cycles(import_graph(tmp_path, ("tools",))) == []
    body = "class Big:\n" + "    x = 1\n" * 300
    (pkg / "big.py").write_text(body)
    (pkg / "ok.py").write_text("class Ok:\n" + "    x = 1\n" * 299)
    assert long_classes(tmp_path, ("tools",)) == ["tools/big.py:1 Big (301 lines)"]
