"""A student's fly.launch: the static_transform_publisher line, read without ROS.

The lab adds one node to its launch file::

    <node pkg="tf2_ros" type="static_transform_publisher" name="tower_broadcaster"
          args="x y z yaw pitch roll frame_id child_frame_id"/>

:func:`read_launch` finds it (the first node whose type is static_transform_publisher) and
returns its args text and the line it is on, or why it cannot be used. Parsing the args into a
transform is common.scenario.parse_static_transform's job (the one parser of that form).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

LAUNCH_FILE = "fly.launch"
PUBLISHER = "static_transform_publisher"


@dataclass(frozen=True)
class LaunchLine:
    """The static transform of a launch file: `args` (None when unusable), its `line`, and `problem`."""
    path: Path
    args: str | None
    line: int | None
    problem: str | None = None          # why there is no usable args text
    not_done: bool = False              # the TODO is still there (or the file is missing)

    @property
    def where(self) -> str:
        return f"{self.path.name} line {self.line}" if self.line else self.path.name


def _line_of(text: str, pattern: str) -> int | None:
    for i, line in enumerate(text.splitlines(), 1):
        if re.search(pattern, line):
            return i
    return None


def read_launch(path: str | Path) -> LaunchLine:
    """The static_transform_publisher of `path` (a missing or broken file says so, never raises)."""
    path = Path(path)
    if not path.exists():
        return LaunchLine(path, None, None, f"no {path.name}: write it (towerlink lab init makes one)", True)
    text = path.read_text(errors="replace")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        return LaunchLine(path, None, exc.position[0], f"{path.name} is not valid XML: {exc}")
    nodes = [n for n in root.iter("node") if n.get("type") == PUBLISHER]
    if not nodes:
        return LaunchLine(path, None, None, f"no <node type=\"{PUBLISHER}\"> in {path.name}", True)
    args = (nodes[0].get("args") or "").strip()
    line = _line_of(text, r"type\s*=\s*[\"']" + PUBLISHER)
    if not args or "TODO" in args.upper():
        return LaunchLine(path, None, line, f"the static transform's args still say {args or 'nothing'!r}", True)
    return LaunchLine(path, args, line)
