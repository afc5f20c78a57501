"""Scenario frames: the lab's self-checkpoint table, point conversion, the frame tree.

  towerlink frames checkpoint              the seven world -> tower rows of the lab
  towerlink frames convert --from world --to tower 0 10
  towerlink frames tree                    every frame and its parent (tf2's text form)

All use the static frames of a scenario file (--scenario; the built-in default
reproduces the lab's tower). Coordinates are NED: x north, y east, z down.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from common.frames import PointStamped, TransformException
from common.scenario import Scenario, ScenarioError, load_scenario

# The lab's self-checkpoint table: world [x, y] -> tower [x, y], rounded to 0.1.
LAB_CHECKPOINT: tuple[tuple[tuple[float, float], tuple[float, float]], ...] = (
    ((0.0, 10.0), (-133.6, 85.9)),
    ((10.0, 10.0), (-124.9, 90.9)),
    ((-10.0, 10.0), (-142.2, 80.9)),
    ((10.0, -10.0), (-114.9, 73.6)),
    ((-100.0, 100.0), (-265.2, 113.9)),
    ((-120.0, 80.0), (-272.5, 86.5)),
    ((-200.0, 100.0), (-351.8, 63.9)),
)


def convert(scenario: Scenario, source: str, target: str, point) -> np.ndarray:
    """The point given in `source` expressed in `target`, through the scenario's frames."""
    buf = scenario.buffer()
    out = buf.transform_point(PointStamped(frame_id=source, stamp=0.0, point=np.asarray(point, float)), target)
    return np.asarray(out.point)


def checkpoint_rows(scenario: Scenario) -> list[tuple[tuple[float, float], tuple[float, float], tuple[float, float]]]:
    """(world input, tower output rounded to 0.1, the lab's expected value) for each table row."""
    rows = []
    for world_xy, expected in LAB_CHECKPOINT:
        p = convert(scenario, "world", "tower", (*world_xy, 0.0))
        rows.append((world_xy, (round(float(p[0]), 1) + 0.0, round(float(p[1]), 1) + 0.0), expected))
    return rows


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scenario", help="scenario TOML (default: the built-in lab scenario)")
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    sub.add_parser("checkpoint", help="print the lab's seven world -> tower rows, with the lab's values")
    conv = sub.add_parser("convert", help="convert a point between any two frames of the scenario")
    conv.add_argument("--from", dest="source", required=True, metavar="FRAME", help="frame the point is given in")
    conv.add_argument("--to", dest="target", required=True, metavar="FRAME", help="frame to express it in")
    conv.add_argument("coords", nargs="+", type=float, metavar="X Y [Z]", help="the point (z defaults to 0)")
    sub.add_parser("tree", help="every frame with its parent")


def run(args: argparse.Namespace) -> int:
    try:
        scenario = load_scenario(args.scenario)
        if args.action == "checkpoint":
            return _print_checkpoint(scenario)
        if args.action == "convert":
            if len(args.coords) not in (2, 3):
                print("towerlink frames convert: give X Y or X Y Z", file=sys.stderr)
                return 2
            xyz = (*args.coords, 0.0)[:3]
            p = convert(scenario, args.source, args.target, xyz)
            print(f"{args.source} [{xyz[0]:.3f}, {xyz[1]:.3f}, {xyz[2]:.3f}] -> "
                  f"{args.target} [{p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}]")
            return 0
        print(scenario.buffer().all_frames_as_string(), end="")
        return 0
    except (ScenarioError, TransformException) as exc:
        print(f"towerlink frames: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1


def _print_checkpoint(scenario: Scenario) -> int:
    print(f"Self-checkpoint, world -> tower, from {scenario.path.name} (rounded to 0.1):")
    ok = True
    for world_xy, got, expected in checkpoint_rows(scenario):
        match = got == expected
        ok &= match
        print(f"  World [{world_xy[0]:.1f}, {world_xy[1]:.1f}] -> Tower [{got[0]:.1f}, {got[1]:.1f}]"
              f"   lab: [{expected[0]:.1f}, {expected[1]:.1f}] {'ok' if match else 'MISMATCH'}")
    print("all 7 rows match the lab" if ok else "some rows do not match the lab")
    return 0 if ok else 1
