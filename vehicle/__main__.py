"""`python -m vehicle`: the same as `towerlink sitl` (built here, so the vehicle needs no tools/)."""
import argparse
import sys

from vehicle import cli


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m vehicle", description=(cli.__doc__ or "").strip(),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    cli.add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return int(cli.run(args) or 0)
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
