"""The `towerlink` command: one entry point whose subcommands are the tools.

Each subcommand lives in its own module, imported only when it runs, so
`towerlink --help` is instant and a tool's heavy imports cost nothing to the
others. A tool module provides:

    def add_arguments(parser: argparse.ArgumentParser) -> None
    def run(args: argparse.Namespace) -> int

and optionally a module docstring, used as the subcommand's long help.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys

# name -> (module, one-line summary). Order is the order `--help` lists them.
COMMANDS: dict[str, tuple[str, str]] = {
    "fly": ("tools.fly", "start world, bridge and tower; fly the scenario; summarise (make demo)"),
    "sitl": ("vehicle.cli", "start the SITL world: drone (sysid 1) and rover (sysid 2) over MAVLink 2"),
    "bridge": ("bridge.cli", "route MAVLink tower<->vehicles, translate frames, drive the rover follow"),
    "tower": ("gcs.tower", "the tower GCS: send goals in the tower frame and wait for each"),
    "frames": ("tools.frames_cmd", "scenario frames: the lab checkpoint table, convert points between frames"),
    "static-transform": ("tools.static_transform", "validate a static transform and print it both ways (tf_echo shape)"),
    "tf-echo": ("tools.tf_echo", "print a transform live from the bridge or offline from a tlog"),
    "view-frames": ("tools.view_frames", "draw the frame tree with per-edge statistics (PDF/PNG/SVG + text)"),
    "view": ("tools.live_view", "serve the bridge's stream live to Foxglove (WebSocket; needs towerlink[view])"),
    "plot": ("tools.plot_tracks", "plot the tracks of a run folder or tlog"),
    "bench": ("tools.bench", "run the benchmarks, peers side by side"),
    "sweep": ("tools.sweep", "fly many seeded variations of a mission on Ray; one table, plots, effects"),
    "lab": ("tools.lab.cli", "the lab as a course: `lab init DIR` (skeletons), `lab check DIR...` (report card)"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="towerlink",
        description="towerlink: a MAVLink SITL flight stack with a tf2-grade frame bridge.",
        epilog="Run `towerlink COMMAND --help` for a command's options.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_module, summary) in COMMANDS.items():
        sub.add_parser(name, help=summary, add_help=False)
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    top = build_parser()
    if not argv or argv[0] in ("-h", "--help"):
        top.print_help()
        return 0
    name = argv[0]
    if name not in COMMANDS:
        top.error(f"unknown command {name!r}; choose from {', '.join(COMMANDS)}")
    module_name, summary = COMMANDS[name]
    module = importlib.import_module(module_name)
    parser = argparse.ArgumentParser(
        prog=f"towerlink {name}",
        description=(module.__doc__ or summary).strip(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    module.add_arguments(parser)
    args = parser.parse_args(argv[1:])
    try:
        return int(module.run(args) or 0)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:     # `towerlink ... | head`: the reader left; no traceback
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 141


if __name__ == "__main__":
    sys.exit(main())
