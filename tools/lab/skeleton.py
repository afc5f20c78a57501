"""`towerlink lab init DIR`: the student's starting point, from the templates shipped with towerlink.

The three nodes as skeletons with the lab's TODOs (on common.tf2_ros), fly.launch with the
static_transform_publisher line to fill in, and a README that walks the lab's steps.
"""
from __future__ import annotations

import stat
from pathlib import Path

from tools.lab.submission import NODES, TEMPLATES

FILES = (*(f"{n}.py" for n in NODES), "fly.launch", "README.md")


def write_skeleton(folder: str | Path, force: bool = False) -> list[Path]:
    """Write the lab's files into `folder` (made if needed); FileExistsError rather than
    overwrite a student's file, unless `force`."""
    d = Path(folder)
    clash = [d / f for f in FILES if (d / f).exists()]
    if clash and not force:
        raise FileExistsError(f"{', '.join(str(p) for p in clash)} already there (--force overwrites)")
    d.mkdir(parents=True, exist_ok=True)
    out = []
    for f in FILES:
        p = d / f
        p.write_text((TEMPLATES / f).read_text())
        if f.endswith(".py"):       # the lab's "remember to make the file executable"
            p.chmod(p.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
        out.append(p)
    return out


__all__ = ["write_skeleton", "FILES"]
