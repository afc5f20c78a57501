"""`python -m vehicle`: the same as `towerlink sitl`."""
import sys

from tools.cli import main

if __name__ == "__main__":
    sys.exit(main(["sitl", *sys.argv[1:]]))
