"""python -m gcs.dialect [--check] [--output PATH]: generate the dialect module with mavgen."""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from . import generate, load, module_path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m gcs.dialect", description=__doc__)
    p.add_argument("--check", action="store_true",
                   help="compare the cached module with a fresh mavgen run; exit 1 if different")
    p.add_argument("--output", help="also write a copy here")
    a = p.parse_args(argv)
    load()
    path = module_path()
    if a.check:
        with tempfile.TemporaryDirectory() as tmp:
            same = generate(Path(tmp) / "towerlink.py").read_bytes() == path.read_bytes()
        print("up to date" if same else f"{path} differs from a fresh mavgen run")
        return 0 if same else 1
    if a.output:
        print(f"wrote {generate(a.output)}")
    print(f"dialect module: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
