"""Reading a student's node file without running it: where the calls a hint is about are.

The evidence of a run says *what* went wrong (the drone was sent to the tower's coordinates,
the stamps are wall-clock seconds); this says *where*: the line of the lookup_transform call
and its frames, of the clock read, of the PointStamped, of a TODO still there. Pure: ast on the
file's text; a file that does not parse has its syntax error instead.
"""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

WALL_CLOCKS = ("time.time", "time.monotonic", "time.perf_counter", "time.time_ns", "datetime.now",
               "datetime.datetime.now", "datetime.utcnow", "node.now", "self.node.now")


@dataclass(frozen=True)
class Call:
    line: int
    name: str                       # the called name as written, e.g. "self.buffer.lookup_transform"
    args: tuple                     # each positional argument: its constant value, else its source text


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    if isinstance(node, ast.Call):
        return _dotted(node.func) + "()"
    return ""


class Source:
    """One node file: its calls, TODO comments and lines (`error` when it does not parse)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.text = self.path.read_text(errors="replace") if self.path.exists() else ""
        self.lines = self.text.splitlines()
        self.error: str | None = None
        self.error_line: int | None = None
        self._calls: list[Call] = []
        try:
            tree = ast.parse(self.text, filename=self.path.name)
        except SyntaxError as exc:
            self.error, self.error_line = f"SyntaxError: {exc.msg}", exc.lineno
            return
        for n in ast.walk(tree):
            if isinstance(n, ast.Call):
                args = tuple(a.value if isinstance(a, ast.Constant) else ast.get_source_segment(self.text, a) or ""
                             for a in n.args)
                self._calls.append(Call(n.lineno, _dotted(n.func), args))
        self._calls.sort(key=lambda c: c.line)

    @property
    def name(self) -> str:
        return self.path.name

    def calls(self, name: str) -> list[Call]:
        """Calls whose name ends with `name` (".lookup_transform" finds self.buffer.lookup_transform)."""
        return [c for c in self._calls if c.name == name or c.name.endswith("." + name)]

    def first_line(self, pattern: str) -> int | None:
        """The first line (1-based) matching a regex, comments included."""
        rx = re.compile(pattern)
        return next((i for i, line in enumerate(self.lines, 1) if rx.search(line)), None)

    def todos(self) -> list[int]:
        """Lines whose comment still says TODO."""
        return [i for i, line in enumerate(self.lines, 1) if re.search(r"#.*\bTODO\b", line)]

    def wall_clock_reads(self) -> list[Call]:
        """time.time(), datetime.now(), node.now() and the like: not the vehicle's clock."""
        return [c for c in self._calls if c.name in WALL_CLOCKS]

    def lookups(self) -> list[Call]:
        return self.calls("lookup_transform")
