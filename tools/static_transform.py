"""Validate a static transform and print it both ways, as tf_echo would.

  towerlink static-transform X Y Z YAW PITCH ROLL FRAME_ID CHILD_FRAME_ID
  towerlink static-transform X Y Z QX QY QZ QW FRAME_ID CHILD_FRAME_ID

The arguments are static_transform_publisher's: the child's origin in the
parent frame (metres) and its orientation, as yaw pitch roll in radians
(R = Rz(yaw) Ry(pitch) Rx(roll); in NED a positive yaw turns x toward y,
clockwise seen from above) or as a quaternion (x y z w). Example, the lab's
tower (Checkpoint 0):

  towerlink static-transform 72.72144 -131.19296 0 -0.5235987756 0 0 world tower

prints `tf_echo world tower` (the pose of tower in world), `tf_echo tower world`
(its inverse) and both 4x4 matrices. With --publish URL it also sends the
transform to a running bridge, which adds it to its frame tree.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from common.mavlink.signing import add_signing_argument
from common.frames import InvalidArgumentException, TransformStamped
from common.frames.arguments import checked_insert
from common.scenario import STATIC_TRANSFORM_USAGE, ScenarioError, parse_static_transform
from tools.tf_format import format_number, format_tf_echo


def describe(ts: TransformStamped) -> str:
    """Both directions in tf_echo's shape, the 4x4 matrices, and how they relate."""
    forward = ts.transform
    inverse = forward.inverse()
    parent, child = ts.frame_id, ts.child_frame_id
    blocks = [
        f"$ tf_echo {parent} {child}    # pose of {child} in {parent}; maps {child} points into {parent}",
        format_tf_echo(forward, time=0.0),
        "- Matrix:",
        _matrix(forward.to_matrix()),
        "",
        f"$ tf_echo {child} {parent}    # the inverse: maps {parent} points into {child}",
        format_tf_echo(inverse, time=0.0),
        "- Matrix:",
        _matrix(inverse.to_matrix()),
        "",
        "The two directions are inverses: the rotation is transposed (quaternion conjugated)",
        "and the translation becomes -R^T t, so their matrices multiply to the identity.",
    ]
    return "\n".join(blocks)


def _matrix(m: np.ndarray) -> str:
    return "\n".join("    " + " ".join(format_number(v, 4).rjust(10) for v in row) for row in m)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("values", nargs="+", metavar="ARG",
                        help=f"{STATIC_TRANSFORM_USAGE} (static_transform_publisher's order)")
    parser.add_argument("--publish", metavar="URL",
                        help="also send it to a running bridge's tower port, e.g. udpout:127.0.0.1:14600, "
                             "and wait for the bridge to accept or refuse it")
    parser.add_argument("--timeout", type=float, default=3.0, metavar="S",
                        help="wall seconds to wait for the bridge's answer with --publish (default 3)")
    add_signing_argument(parser, "sign the request (MAVLink 2), for a bridge started with --signing-key: {forms}")
    parser.add_argument("--sysid", type=int, default=255,
                        help="sysid to send as (default 255; the bridge trusts --trust-sysid, default 255)")


def run(args: argparse.Namespace) -> int:
    try:
        ts = parse_static_transform(args.values)
        # the buffer's own checks of what it stores: ids, and no transform from a frame to
        # itself (tf2's static_transform_publisher refuses that too)
        checked_insert(ts, "static transform")
    except (ScenarioError, InvalidArgumentException) as exc:
        print(f"towerlink static-transform: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 2
    print(describe(ts))
    if args.publish:
        from bridge.static_publisher import publish_static  # the bridge's own sender; imported only when used
        try:
            from common.mavlink.signing import key_from_text
            verdict = publish_static(args.publish, ts, timeout=args.timeout, source_system=args.sysid,
                                     signing_key=key_from_text(args.signing_key))
        except TimeoutError as exc:
            print(f"towerlink static-transform: {exc}", file=sys.stderr)
            return 1
        print(f"\nbridge at {args.publish}: {verdict}")
        return 0 if "added" in verdict else 1
    return 0
