"""towerlink tf-echo SOURCE TARGET: print a transform in tf2_echo's shape.

Like ROS `tf_echo source_frame target_frame`, it prints
lookup_transform(SOURCE, TARGET): the pose of TARGET expressed in SOURCE, i.e. the
transform that maps points given in TARGET into SOURCE. `tf-echo world tower` prints
where the tower is in the world; `tf-echo tower world` its inverse.

Live (default): listen for the bridge's transform stream (TOWERLINK_TRANSFORM) on
--connect (default udpin:127.0.0.1:14610; start the bridge with
`--out udpout:127.0.0.1:14610`), fill a frame Buffer, and print the latest
transform at --rate Hz (LATEST = the latest common time, as tf2_echo does).

Offline: --tlog FILE reads a tlog (pymavlink / MAVProxy / the tower's), or a run's
MCAP recording (a FILE ending in .mcap: its /tf and /tf_static channels), and prints the
transform at --time T (sim seconds, interpolated like tf2), or at every stamp of the
chain's dynamic edges when --time is not given (once, at time 0, for a static chain).

  At time 12.340
  - Translation: [x, y, z]
  - Rotation: in Quaternion [x, y, z, w]
              in RPY (radian) [roll, pitch, yaw]
              in RPY (degree) [roll, pitch, yaw]

--count N stops after N prints. Exit status 0 when something was printed, 1 when
the transform never became available (with --timeout or offline), 2 on bad input.
"""
from __future__ import annotations

import argparse
import sys
import time

from tools.tf_format import format_tf_echo

DEFAULT_CONNECT = "udpin:127.0.0.1:14610"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("source_frame", help="frame the result is expressed in (tf2_echo's first argument)")
    p.add_argument("target_frame", help="frame whose pose is printed")
    p.add_argument("--connect", default=DEFAULT_CONNECT,
                   help="live: where the bridge's transform stream arrives (default %(default)s)")
    p.add_argument("--tlog", default=None,
                   help="offline: read this tlog (or run.mcap, by its .mcap ending) instead of listening")
    p.add_argument("--time", type=float, default=None, help="offline: sim time to look up (s)")
    p.add_argument("--rate", type=float, default=1.0, help="live: prints per second (default %(default)s)")
    p.add_argument("--count", type=int, default=None, help="stop after N prints")
    p.add_argument("--timeout", type=float, default=None,
                   help="live: give up (exit 1) if nothing could be printed within this many seconds")
    p.add_argument("--precision", type=int, default=3, help="decimals (default %(default)s, as tf2_echo)")


def _print(ts, precision: int) -> None:
    print(format_tf_echo(ts, ts.stamp, precision), flush=True)


def read_tlog(path: str, cache_time: float = 1e9):
    """A TransformListener filled with every TOWERLINK_TRANSFORM of a tlog (no window)."""
    from common.mavlink.dialect import mavlink_connection
    from common.frames import Buffer
    from bridge.listener import TransformListener

    lis = TransformListener(Buffer(cache_time=cache_time))
    lis.stamps = {}     # child frame -> stamps of its dynamic samples
    conn = mavlink_connection(path, notimestamps=False)
    try:
        while True:
            m = conn.recv_msg()     # not recv_match(type=): pymavlink's tlog index skips dialect ids
            if m is None:
                break
            if m.get_type() == "TOWERLINK_TRANSFORM" and lis.feed(m) and not m.flags & 1:
                lis.stamps.setdefault(m.child_frame_id, set()).add(m.time_usec / 1e6)
    finally:
        conn.close()
    return lis


def read_mcap(path: str):
    """The same shape as read_tlog's listener (.buffer, .stamps), from a run.mcap."""
    from types import SimpleNamespace
    from tools.run_mcap import buffer_from_mcap

    buf, stamps, _latest = buffer_from_mcap(path)
    return SimpleNamespace(buffer=buf, stamps=stamps)


def run_offline(args) -> int:
    from common.frames import LATEST, TransformException

    from tools.recording_file import require_recording

    try:
        require_recording(args.tlog)
        lis = read_mcap(args.tlog) if str(args.tlog).endswith(".mcap") else read_tlog(args.tlog)
    except OSError as exc:
        print(f"tf-echo: {exc}", file=sys.stderr)
        return 2
    buf = lis.buffer
    src, tgt = args.source_frame, args.target_frame
    if args.time is not None:
        times = [args.time]
    else:
        try:
            chain = buf.chain(src, tgt)
        except TransformException as exc:
            print(f"tf-echo: {exc}\nFrames in {args.tlog}:\n{buf.all_frames_as_string()}", file=sys.stderr)
            return 1
        stats = buf.edge_stats()
        dyn = [f for f in chain if f in stats and not stats[f].is_static]
        if not dyn:
            times = [LATEST]
        else:
            stamps = set()
            for f in dyn:
                stamps.update(lis.stamps.get(f, ()))
            times = sorted(stamps)
    printed = 0
    last_err = None
    for t in times:
        try:
            ts = buf.lookup_transform(src, tgt, t)
        except TransformException as exc:
            last_err = exc
            continue
        _print(ts, args.precision)
        printed += 1
        if args.count is not None and printed >= args.count:
            break
    if not printed:
        print(f"tf-echo: no transform {src} <- {tgt} in {args.tlog}: {last_err}\n"
              f"Frames:\n{buf.all_frames_as_string()}", file=sys.stderr)
        return 1
    return 0


def run_live(args) -> int:
    from common.mavlink.dialect import mavlink_connection
    from common.frames import LATEST, TransformException
    from bridge.listener import TransformListener

    try:
        conn = mavlink_connection(args.connect, source_system=254, source_component=195)
    except Exception as exc:
        print(f"tf-echo: cannot open {args.connect}: {exc}", file=sys.stderr)
        return 2
    lis = TransformListener()
    period = 1.0 / max(args.rate, 1e-3)
    start = time.monotonic()
    next_print = start + min(period, 0.5)
    printed = 0
    last_warn = 0.0
    try:
        while True:
            now = time.monotonic()
            m = conn.recv_match(type="TOWERLINK_TRANSFORM", blocking=True,
                                timeout=max(0.0, min(0.05, next_print - now)))
            if m is not None:
                lis.feed(m)
                continue
            now = time.monotonic()
            if now < next_print:
                continue
            next_print += period
            if next_print < now:
                next_print = now + period
            try:
                ts = lis.buffer.lookup_transform(args.source_frame, args.target_frame, LATEST)
            except TransformException as exc:
                if args.timeout is not None and now - start > args.timeout:
                    print(f"tf-echo: gave up after {args.timeout} s: {exc}", file=sys.stderr)
                    return 1
                if now - last_warn > 1.0:
                    last_warn = now
                    print(f"Waiting for transform {args.source_frame} <- {args.target_frame}: {exc}",
                          file=sys.stderr, flush=True)
                continue
            _print(ts, args.precision)
            printed += 1
            if args.count is not None and printed >= args.count:
                return 0
    finally:
        conn.close()


def run(args) -> int:
    if args.tlog:
        return run_offline(args)
    return run_live(args)
