"""What a check finds: one Checkpoint result per checkpoint, each with its figures, notes and hints."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

TITLES = {0: "static transform", 1: "tower goals", 2: "follow through drone", 3: "yaw-only frame"}
NOT_DONE = "not done yet"


@dataclass(frozen=True)
class Hint:
    """A likely mistake, from the evidence: where to look (file, line) and why."""
    file: str
    line: int | None
    text: str

    def __str__(self) -> str:
        return f"{self.file}{f' line {self.line}' if self.line else ''}: {self.text}"


@dataclass
class Checkpoint:
    number: int
    passed: bool
    measured: str                               # the figures, in one line
    figures: dict[str, Any] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    hints: list[Hint] = field(default_factory=list)
    details: str = ""                           # markdown for report.md (tables, tf_echo blocks)
    not_done: bool = False                      # the student's part is still the skeleton's

    @property
    def title(self) -> str:
        return TITLES[self.number]

    @property
    def verdict(self) -> str:
        return "PASS" if self.passed else "FAIL"

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["title"], d["verdict"] = self.title, self.verdict
        d["hints"] = [{**asdict(h), "text": h.text, "where": str(h)} for h in self.hints]
        return d


def not_done(number: int, why: str, hints: list[Hint] | None = None) -> Checkpoint:
    """A checkpoint whose part is not written yet."""
    return Checkpoint(number, False, f"{NOT_DONE}: {why}", hints=hints or [], not_done=True)


def not_flown(number: int, run) -> "Checkpoint | None":
    """A checkpoint whose flight never got going (the machine, not the student), or None."""
    if run.sim > 0:
        return None
    return Checkpoint(number, False, "the flight did not run",
                      notes=[f"flight {run.dir.name} could not run: {run.failure or 'no sim time passed'}"])
