"""Benchmark common.frames against its peers, side by side, in one run.

Rows:
  * interpolated lookup over the 3-hop chain tower <- world <- drone <- drone_yaw
    (world->tower static, world->drone dynamic 100 Hz, drone->drone_yaw dynamic
    100 Hz, 10 s of data), at times between samples that change on every call,
    vs pytransform3d's TemporalTransformManager on the same chain
    (StaticTransform + NumpyTimeseriesTransform);
  * batched apply of a rigid transform to 1e6 points vs scipy Rotation.apply
    (rotation only, so the vector row is the like-for-like comparison);
  * inserts per second into a Buffer (pre-built TransformStamped, 100 Hz stamps,
    10 s window, so pruning runs), and with the TransformStamped built per insert.

Usage: python -m tools.bench_frames [--quick]
"""
from __future__ import annotations

import argparse
import math
import random
import sys

import numpy as np

from common.frames import Buffer, Transform, TransformStamped
from tools.benchtable import machine, median_time, table

LOOKUP_TARGET_US = 5.0
APPLY_TARGET_PTS = 50e6
INSERT_TARGET_PER_S = 200e3

RATE_HZ = 100.0
SECONDS = 10.0


def _drone_samples(n: int) -> tuple[np.ndarray, list[Transform], list[Transform]]:
    rng = random.Random(1)
    times = np.arange(n) / RATE_HZ
    drone, yaw = [], []
    for t in times:
        yw, pitch, roll = 0.3 * t, 0.1 * math.sin(t), 0.05 * math.cos(1.3 * t)
        xyz = (5 * math.cos(0.2 * t), 5 * math.sin(0.2 * t), -10.0 + rng.uniform(-0.01, 0.01))
        drone.append(Transform.from_euler(yaw=yw, pitch=pitch, roll=roll, translation=xyz))
        # drone -> drone_yaw: undo roll and pitch (a yaw-only frame at the drone's origin)
        yaw.append(Transform.from_euler(pitch=-pitch) * Transform.from_euler(roll=-roll))
    return times, drone, yaw


def _towerlink_chain(times, drone, yaw) -> Buffer:
    buf = Buffer(cache_time=SECONDS + 1.0)
    buf.set_transform_static(TransformStamped(
        "world", "tower", 0.0, Transform.from_euler(yaw=0.6, translation=(-133.6, 85.9, -2.0))), "bench")
    for t, d, y in zip(times.tolist(), drone, yaw):
        buf.set_transform(TransformStamped("world", "drone", t, d), "bench")
        buf.set_transform(TransformStamped("drone", "drone_yaw", t, y), "bench")
    return buf


def _pq(tf: Transform) -> list[float]:
    x, y, z, qx, qy, qz, qw = tf.to_tuple()
    return [x, y, z, qw, qx, qy, qz]  # pytransform3d's (x, y, z, qw, qx, qy, qz)


def _pytransform3d_chain(times, drone, yaw):
    from pytransform3d.transform_manager import (NumpyTimeseriesTransform, StaticTransform,
                                                 TemporalTransformManager)
    tm = TemporalTransformManager(check=False)
    tower = Transform.from_euler(yaw=0.6, translation=(-133.6, 85.9, -2.0))
    tm.add_transform("tower", "world", StaticTransform(tower.to_matrix()))
    tm.add_transform("drone", "world", NumpyTimeseriesTransform(times, np.array([_pq(d) for d in drone])))
    tm.add_transform("drone_yaw", "drone", NumpyTimeseriesTransform(times, np.array([_pq(y) for y in yaw])))
    return tm


def _fmt_rate(x: float) -> str:
    if x >= 1e6:
        return f"{x / 1e6:.1f} M/s"
    return f"{x / 1e3:.0f} k/s"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats (for smoke tests)")
    args = ap.parse_args(argv)
    rep = 5 if args.quick else 21

    n = int(RATE_HZ * SECONDS)
    times, drone, yaw = _drone_samples(n)
    buf = _towerlink_chain(times, drone, yaw)
    rng = np.random.default_rng(2)
    # interpolated times strictly between samples, a different one per call
    qt = ((np.arange(n - 1) + rng.uniform(0.1, 0.9, n - 1)) / RATE_HZ)
    qt = qt[rng.permutation(len(qt))].tolist()
    lookup = buf.lookup_transform

    # many short samples (100 lookups each): on a shared machine a preempted sample
    # only spoils itself, and the median ignores it
    batches = [qt[i:i + 100] for i in range(0, len(qt) - 99, 100)]
    it = iter(())

    def towerlink_lookups():
        nonlocal it
        batch = next(it, None)
        if batch is None:
            it = iter(batches)
            batch = next(it)
        for t in batch:
            lookup("tower", "drone_yaw", t)

    # correctness guard: the chain equals the product of its edges
    t_chk = qt[0]
    got = lookup("tower", "drone_yaw", t_chk).transform
    ref = (lookup("world", "tower", t_chk).transform.inverse() * lookup("world", "drone", t_chk).transform
           * lookup("drone", "drone_yaw", t_chk).transform)
    assert got.almost_equal(ref, 1e-9), (got, ref)

    towerlink_lookups()  # warm caches
    tl_us = median_time(towerlink_lookups, repeat=rep * 20) / 100 * 1e6

    rows = []
    try:
        tm = _pytransform3d_chain(times, drone, yaw)
        q_pt = qt[: (50 if args.quick else 200)]
        m = tm.get_transform_at_time("drone_yaw", "tower", qt[0])  # maps drone_yaw into tower
        assert np.allclose(m[:3, 3], got.translation, atol=1e-3), (m[:3, 3], got.translation)

        def pt3d_lookups():
            for t in q_pt:
                tm.get_transform_at_time("drone_yaw", "tower", t)

        pt_us = median_time(pt3d_lookups, repeat=max(3, rep // 3)) / len(q_pt) * 1e6
        pt_cell, ratio = f"{pt_us:.1f} µs", f"{pt_us / tl_us:.0f}x faster"
    except ImportError:
        pt_cell, ratio = "not installed", "-"
    rows.append(["interpolated lookup, 3-hop chain (median)", f"{tl_us:.2f} µs",
                 "pytransform3d TemporalTransformManager", pt_cell, ratio,
                 f"<= {LOOKUP_TARGET_US:.0f} µs", "met" if tl_us <= LOOKUP_TARGET_US else "MISSED"])

    # ---- batched apply
    from scipy.spatial.transform import Rotation
    npts = 1_000_000
    pts = np.random.default_rng(3).uniform(-100, 100, (npts, 3))
    tf = Transform.from_euler(yaw=0.3, pitch=0.2, roll=0.1, translation=(1.0, 2.0, 3.0))
    rot = Rotation.from_quat(np.asarray(tf.rotation))
    for _ in range(2):  # warm: allocator, BLAS, caches
        tf.apply_point(pts), tf.apply_vector(pts), rot.apply(pts)
    arep = 7 if args.quick else 25
    p_rate = npts / median_time(lambda: tf.apply_point(pts), repeat=arep)
    v_rate = npts / median_time(lambda: tf.apply_vector(pts), repeat=arep)
    s_rate = npts / median_time(lambda: rot.apply(pts), repeat=arep)
    rows.append(["apply_point, 1e6 points (R p + t)", _fmt_rate(p_rate).replace("/s", " pts/s"),
                 "scipy Rotation.apply (R p only)", _fmt_rate(s_rate).replace("/s", " pts/s"),
                 f"{p_rate / s_rate:.2f}x", f">= {APPLY_TARGET_PTS / 1e6:.0f} M pts/s",
                 "met" if p_rate >= APPLY_TARGET_PTS else "MISSED"])
    rows.append(["apply_vector, 1e6 vectors (R v)", _fmt_rate(v_rate).replace("/s", " pts/s"),
                 "scipy Rotation.apply (R v)", _fmt_rate(s_rate).replace("/s", " pts/s"),
                 f"{v_rate / s_rate:.2f}x", f">= {APPLY_TARGET_PTS / 1e6:.0f} M pts/s",
                 "met" if v_rate >= APPLY_TARGET_PTS else "MISSED"])

    # ---- inserts
    nins = 20_000 if args.quick else 50_000
    stamps = (np.arange(nins) / RATE_HZ).tolist()
    tfs = [drone[i % n] for i in range(nins)]
    prebuilt = [TransformStamped("world", "drone", s, t) for s, t in zip(stamps, tfs)]

    def inserts():
        b = Buffer(cache_time=SECONDS)
        st = b.set_transform
        for m_ in prebuilt:
            st(m_, "bench")

    raw = [(s, t.xyz, t.xyzw) for s, t in zip(stamps, tfs)]  # as telemetry arrives: floats

    def build_and_insert():
        b = Buffer(cache_time=SECONDS)
        st = b.set_transform
        for s, p, q in raw:
            st(TransformStamped("world", "drone", s, Transform(p, q)), "bench")

    irep = 3 if args.quick else 7
    i_rate = nins / median_time(inserts, repeat=irep)
    ib_rate = nins / median_time(build_and_insert, repeat=irep)
    rows.append(["set_transform, pre-built TransformStamped", _fmt_rate(i_rate), "-", "-", "-",
                 f">= {INSERT_TARGET_PER_S / 1e3:.0f} k/s",
                 "met" if i_rate >= INSERT_TARGET_PER_S else "MISSED"])
    rows.append(["set_transform incl. building Transform + TransformStamped", _fmt_rate(ib_rate), "-", "-", "-",
                 f">= {INSERT_TARGET_PER_S / 1e3:.0f} k/s",
                 "met" if ib_rate >= INSERT_TARGET_PER_S else "MISSED"])

    print(machine())
    print(table("common.frames vs peers (median; lower µs / higher rate is better)",
                ["measure", "towerlink", "peer", "peer figure", "ratio", "target", "status"], rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
