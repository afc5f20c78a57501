"""What watching costs: the live Foxglove view and run.mcap, against recording the tlog.

A run's bridge stream is replayed (a synthetic one shaped like the lab's: two vehicles'
telemetry, five frames at 10 Hz of sim time, the follow status) through:

  tlog          what the launcher already does per message (the peer: the recording)
  view, idle    LiveView.on_message with no Foxglove client connected
  view, client  the same with a client subscribed to every channel (in this process), fed at
                the 5x rate; CPU time of the whole process (server threads and client included)
  mcap          run.mcap written from the records after the run (per message of the stream)

The cost is per message of the stream, and as a share of one core at the message rate
`towerlink fly` produces at 5x (make demo's speed). None of it runs in the world's process,
so the simulation itself pays nothing; the share says whether the launcher keeps up.
"""
from __future__ import annotations

import argparse
import io
import math
import os
import struct
import tempfile
import time

from tools.benchtable import machine, table

SIM_S = 60.0
MSGS_PER_SIM_S = 250          # measured on the lab run's bridge.tlog: ~15,000 messages in 62 s


def stream(sim_s: float = SIM_S) -> list:
    """Decoded messages shaped like a lab run's bridge stream, in arrival order."""
    from common.mavlink.dialect import towerlink as tl
    enc_b = tl.MAVLink(None, srcSystem=250, srcComponent=1)
    enc_v = {1: tl.MAVLink(None, srcSystem=1, srcComponent=1), 2: tl.MAVLink(None, srcSystem=2, srcComponent=1)}
    raw = bytearray()
    dt = 0.05
    for k in range(int(sim_s / dt)):
        t = k * dt
        ms = int(t * 1000)
        x = 2.0 * t
        q = [0.0, math.sin(0.1), 0.0, math.cos(0.1)]
        for sysid in (1, 2):
            e = enc_v[sysid]
            raw += tl.MAVLink_local_position_ned_message(ms, x, 0.0, -9.0, 2.0, 0.0, 0.0).pack(e)
            raw += tl.MAVLink_attitude_quaternion_message(ms, q[3], q[0], q[1], q[2], 0, 0, 0, [0, 0, 0, 0]).pack(e)
            raw += tl.MAVLink_global_position_int_message(ms, 0, 0, 0, 9000, 200, 0, 0, 0).pack(e)
            raw += tl.MAVLink_attitude_message(ms, 0.0, 0.2, 0.0, 0, 0, 0).pack(e)
        if k % 2 == 0:
            for child in ("drone", "drone_yaw", "rover", "rover_yaw"):
                raw += tl.MAVLink_towerlink_transform_message(
                    int(t * 1e6), b"world", child.encode(), [x, 0.0, -9.0], q, 0).pack(enc_b)
            raw += tl.MAVLink_towerlink_follow_status_message(
                int(t * 1e6), x, 0, x + 1.8, 0, x, 0, x, 0, 2, 0, x - 0.3, 0, 9, 0.2, 1.8, 0, 1, 1).pack(enc_b)
        if k % 20 == 0:
            raw += tl.MAVLink_towerlink_transform_message(0, b"world", b"tower", [70, -130, 0],
                                                          [0, 0, -0.26, 0.966], 1).pack(enc_b)
    dec = tl.MAVLink(None)
    return dec.parse_buffer(bytes(raw)) or []


def per_message(fn, msgs) -> float:
    t0 = time.perf_counter()
    for m in msgs:
        fn(m)
    return (time.perf_counter() - t0) / len(msgs)


def paced(fn, msgs, rate: float) -> float:
    """CPU seconds per message (this process, every thread: the server's too), feeding at `rate`
    messages per wall second, as `towerlink fly` at 5x delivers them."""
    c0, t0 = time.process_time(), time.perf_counter()
    for k, m in enumerate(msgs):
        fn(m)
        if k % 50 == 49:
            ahead = t0 + (k + 1) / rate - time.perf_counter()
            if ahead > 0:
                time.sleep(ahead)       # pacing a producer, not waiting for a result
    return (time.process_time() - c0) / len(msgs)


def measure(sim_s: float = SIM_S) -> dict:
    msgs = stream(sim_s)
    out = {"n": len(msgs), "rate_5x": len(msgs) / sim_s * 5.0}
    f = io.BytesIO()
    stamp = struct.pack(">Q", 0)
    out["tlog"] = per_message(lambda m: f.write(stamp + m.get_msgbuf()), msgs)
    try:
        from tools.live_view import LiveView
    except ImportError:
        return out
    view = LiveView(port=0)
    try:
        out["view_idle"] = per_message(view.on_message, msgs)
        try:
            from tools.foxglove_client import FoxgloveClient
        except ImportError:        # websockets not installed
            FoxgloveClient = None
        if FoxgloveClient is not None:
            view2 = LiveView(port=0)
            from tools.scene_feed import TOPICS
            client = FoxgloveClient(view2.url, tuple(TOPICS))
            try:
                deadline = time.monotonic() + 10
                while time.monotonic() < deadline and not all(c.has_sinks() for c in view2.channels.values()):
                    time.sleep(0.01)
                out["view_client"] = paced(view2.on_message, msgs, out["rate_5x"])
                deadline = time.monotonic() + 10
                want = sum(1 for m in msgs if m.get_type() == "TOWERLINK_TRANSFORM" and not m.flags & 1)
                while time.monotonic() < deadline and len(client.of("/tf")) < want:
                    time.sleep(0.01)
                out["received_tf"], out["sent_tf"] = len(client.of("/tf")), want
            finally:
                client.stop()
                view2.stop()
    finally:
        view.stop()
    from tools.run_mcap import write_mcap
    from tools.scene_feed import records_of
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        write_mcap(records_of(msgs), os.path.join(tmp, "run.mcap"))
        out["mcap"] = (time.perf_counter() - t0) / len(msgs)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="bench_view", description=__doc__.split("\n\n")[0])
    p.add_argument("--sim", type=float, default=SIM_S, help="sim seconds of stream (default %(default)s)")
    a = p.parse_args(argv)
    r = measure(a.sim)
    print(machine())
    rows = []
    for key, label in (("tlog", "tlog write (peer)"), ("view_idle", "live view, no client"),
                       ("view_client", "live view, client on every channel, paced at 5x (CPU)"), ("mcap", "run.mcap after the run")):
        if key in r:
            us = r[key] * 1e6
            rows.append([label, f"{us:.1f}", f"{r[key] / r['tlog']:.1f}",
                         f"{r[key] * r['rate_5x'] * 100:.2f} %" if key != "mcap" else "after the run"])
    print(table(f"per message of the bridge stream ({r['n']} messages, {r['rate_5x']:.0f} msg/s at 5x)",
                ["", "us/message", "x tlog", "core share at 5x"], rows))
    if "received_tf" in r:
        print(f"client received {r['received_tf']} of {r['sent_tf']} transforms "
              f"({'kept up' if r['received_tf'] >= r['sent_tf'] else 'LOST SOME'})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
