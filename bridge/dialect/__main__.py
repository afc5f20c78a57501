"""python -m bridge.dialect [--check] [--output PATH]: regenerate towerlink.py with mavgen."""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from . import MODULE, generate


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m bridge.dialect", description=__doc__)
    p.add_argument("--check", action="store_true", help="compare with the committed module; exit 1 if different")
    p.add_argument("--output", default=str(MODULE), help="where to write (default: %(default)s)")
    a = p.parse_args(argv)
    if a.check:
        with tempfile.TemporaryDirectory() as tmp:
            out = generate(Path(tmp) / "towerlink.py")
            same = out.read_bytes() == MODULE.read_bytes()
        print("up to date" if same else f"{MODULE} differs from a fresh mavgen run")
        return 0 if same else 1
    print(f"wrote {generate(a.output)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
