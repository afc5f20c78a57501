"""A student's lab folder: the three nodes, fly.launch, and how far each one is from its skeleton.

`towerlink lab init` writes the skeletons (tools/lab/templates); a node whose text is still its
skeleton's (whitespace aside) is *untouched*: its checkpoints are "not done yet" without a flight.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from tools.lab.launch_file import LAUNCH_FILE, LaunchLine, read_launch
from tools.lab.source_scan import Source

NODES = ("tower_to_map", "world_to_drone", "ground_robot_controller")
TEMPLATES = Path(__file__).with_name("templates")


def _norm(text: str) -> str:
    return "\n".join(line.rstrip() for line in text.strip().splitlines())


def template_text(name: str) -> str:
    return (TEMPLATES / name).read_text()


@dataclass
class Submission:
    dir: Path
    launch: LaunchLine
    sources: dict[str, Source] = field(default_factory=dict)      # node name -> its file, read

    @classmethod
    def read(cls, folder: str | Path) -> "Submission":
        d = Path(folder).resolve()
        return cls(d, read_launch(d / LAUNCH_FILE), {n: Source(d / f"{n}.py") for n in NODES})

    @property
    def name(self) -> str:
        return self.dir.name

    def path(self, node: str) -> Path:
        return self.dir / f"{node}.py"

    def missing(self, node: str) -> bool:
        return not self.path(node).exists()

    def untouched(self, node: str) -> bool:
        """Still the skeleton (or missing): nothing of the student's to run."""
        return self.missing(node) or _norm(self.sources[node].text) == _norm(template_text(f"{node}.py"))

    def broken(self, node: str) -> str | None:
        """Why `node` cannot run at all (a syntax error, with its line), or None."""
        src = self.sources[node]
        return None if src.error is None else f"{src.name} line {src.error_line}: {src.error}"

    def all_untouched(self) -> bool:
        return all(self.untouched(n) for n in NODES)
