"""What onboard logging costs: the DataFlash logs every armed vehicle writes, per vehicle-second.

  python -m tools.bench_logs              (or: towerlink bench logs)

Two worlds of N armed vehicles (half drones hovering at 5 m, half rovers driving 200 m),
in process and unpaced, S sim seconds each, run in turns (a third of S at a time) so a
shared machine's load falls on both alike:

  logging off   LOG_BACKEND_TYPE 0 on every vehicle (the peer: the same world, no logs)
  logging on    the default: each vehicle's log sampled at 10 Hz, packed in the step loop,
                written by the writer thread

Per vehicle-second of sim time: CPU of the step loop (the world's thread: what logging adds
to it is what it costs the simulation), CPU of the writer thread (its disk writes), bytes
logged, chunks dropped because the writer fell behind (0: it kept up), and the slowest
autopilot tick (does logging ever hold the loop?). Written to a temporary state dir.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

from tools.benchtable import machine, table

N = 40
SIM_S = 30.0
ROUNDS = 3


def _world(n: int, state_dir: str, logging: bool):
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from vehicle.autopilot import modes
    from vehicle.autopilot.guided import ACC_BITS, VEL_BITS, YAW_IGNORE, YAW_RATE_IGNORE
    from vehicle.world import World, WorldConfig
    POSITION_ONLY = VEL_BITS | ACC_BITS | YAW_IGNORE | YAW_RATE_IGNORE
    w = World(WorldConfig(drones=n // 2, rovers=n - n // 2, state_dir=state_dir, tcp_base=None, udp_base=None))
    for v in w.vehicles:
        v.ap.params.set("LOG_BACKEND_TYPE", 1 if logging else 0, save=False)
    deadline = w.t + 30.0
    while not all(v.ap.est_ok and v.ap.home is not None for v in w.vehicles):
        if w.t > deadline:
            raise RuntimeError("the world's estimates did not settle")
        w.run_for(0.5)
    for v in w.vehicles:
        ap = v.ap
        if v.kind == "copter":
            ap.set_mode(modes.GUIDED)
            ap.arm()
            ap.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 5.0])
        else:
            ap.set_mode(modes.ROVER_GUIDED)
            ap.arm()
            goal = ap.local_origin.to_local(ap.pos + (200.0, 0.0, 0.0))
            ap.position_target_local(mav.MAV_FRAME_LOCAL_NED, POSITION_ONLY, tuple(goal), (0, 0, 0), (0, 0, 0), 0, 0)
    w.run_for(5.0)
    return w


def _run(w, sim_s: float) -> dict:
    """Step the world unpaced for sim_s; CPU of this thread, the slowest autopilot tick."""
    steps = round(sim_s / w.dt)
    writer = w.logs.writer
    c0, wt0, b0 = time.thread_time(), writer.cpu, writer.queued
    slowest = 0.0
    for _ in range(steps):
        t0 = time.perf_counter()
        w.step()
        slowest = max(slowest, time.perf_counter() - t0)
    loop = time.thread_time() - c0
    writer.flush()
    return {"loop": loop, "slowest": slowest, "writer": writer.cpu - wt0, "bytes": writer.queued - b0,
            "dropped": writer.dropped}


def measure(n: int = N, sim_s: float = SIM_S, rounds: int = ROUNDS) -> dict:
    """Both worlds built, then run in turns (off, on, off, on...) for sim_s / rounds each, so a
    shared machine's load falls on both alike; per config the sum of the CPU figures and the
    least-loaded round's slowest step."""
    out = {}
    with tempfile.TemporaryDirectory(prefix="bench_logs") as tmp:
        worlds = {label: _world(n, os.path.join(tmp, label), logging) for label, logging in
                  (("off", False), ("on", True))}
        try:
            for _ in range(rounds):
                for label, w in worlds.items():
                    r = _run(w, sim_s / rounds)
                    acc = out.setdefault(label, {"loop": 0.0, "writer": 0.0, "bytes": 0, "slowest": []})
                    acc["loop"] += r["loop"]
                    acc["writer"] += r["writer"]
                    acc["bytes"] += r["bytes"]
                    acc["slowest"].append(r["slowest"])
                    acc["dropped"] = r["dropped"]
        finally:
            for w in worlds.values():
                for v in w.vehicles:          # what World.run does when it ends
                    v.link.close()
                w.logs.close()
    for acc in out.values():
        acc["slowest"] = min(acc["slowest"])
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="bench_logs", description=__doc__.split("\n\n")[0])
    p.add_argument("--vehicles", type=int, default=N, help="armed vehicles, half drones (default %(default)s)")
    p.add_argument("--sim", type=float, default=SIM_S, help="sim seconds measured (default %(default)s)")
    a = p.parse_args(argv)
    r = measure(a.vehicles, a.sim)
    vs = a.vehicles * a.sim
    off, on = r["off"], r["on"]
    print(machine(), f"| load {os.getloadavg()[0]:.1f}")

    def us(s: float) -> str:                     # µs per vehicle-second
        return f"{s / vs * 1e6:.0f}"
    rows = [["step loop CPU (world thread)", us(off["loop"]), us(on["loop"]), us(on["loop"] - off["loop"])],
            ["writer thread CPU", "-", us(on.get("writer", 0.0)), us(on.get("writer", 0.0))],
            ["slowest world step (ms)", f"{off['slowest'] * 1e3:.1f}", f"{on['slowest'] * 1e3:.1f}", "-"]]
    print(table(f"onboard logs, {a.vehicles} armed vehicles, {a.sim:g} sim s unpaced (µs per vehicle-second)",
                ["", "logging off (peer)", "logging on", "logging's cost"], rows))
    added = (on["loop"] - off["loop"] + on.get("writer", 0.0)) / vs
    print(f"log writer's cost: {added * 1e6:.0f} µs CPU per vehicle-second "
          f"({added * 100:.2f} % of a core per armed vehicle at real time); "
          f"{on.get('bytes', 0) / vs / 1024:.1f} kB logged per vehicle-second, "
          f"{on.get('dropped', 0)} bytes dropped")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
