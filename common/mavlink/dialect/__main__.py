"""python -m common.mavlink.dialect [--check] [--output PATH] [--install]: generate the dialect module with mavgen.

--install puts the dialect where pymavlink's own tools look for one (pymavlink/dialects/v20/
towerlink.xml and .py in the installed pymavlink), so they decode TOWERLINK_* messages:

    python -m common.mavlink.dialect --install
    MAVLINK20=1 mavlogdump.py --dialect towerlink --types TOWERLINK_TRANSFORM runs/<run>/bridge.tlog
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from . import XML, generate, load, module_path


def install_into_pymavlink() -> list[Path]:
    """Copy the XML and the generated module into pymavlink/dialects/v20 (atomically each)."""
    import os
    import shutil

    import pymavlink
    dest = Path(pymavlink.__file__).resolve().parent / "dialects" / "v20"
    done = []
    for src, name in ((XML, "towerlink.xml"), (module_path(), "towerlink.py")):
        tmp = dest / f".{name}.tmp"
        shutil.copyfile(src, tmp)
        os.replace(tmp, dest / name)
        done.append(dest / name)
    return done


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m common.mavlink.dialect", description=__doc__)
    p.add_argument("--check", action="store_true",
                   help="compare the cached module with a fresh mavgen run; exit 1 if different")
    p.add_argument("--output", help="also write a copy here")
    p.add_argument("--install", action="store_true",
                   help="install towerlink.xml and the module into the installed pymavlink's dialects "
                        "(for mavlogdump.py --dialect towerlink and other pymavlink tools)")
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
    if a.install:
        try:
            for f in install_into_pymavlink():
                print(f"installed {f}")
        except OSError as exc:
            print(f"python -m common.mavlink.dialect: cannot install into pymavlink: {exc}", file=sys.stderr)
            return 1
    print(f"dialect module: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
