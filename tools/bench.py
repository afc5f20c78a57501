"""Run the benchmarks, each with its peer measured side by side in the same run.

  towerlink bench                 all of them (what `make bench` runs)
  towerlink bench frames flight   a selection

frames: interpolated lookup vs pytransform3d, batched points vs scipy, inserts.
flight: one drone vs RotorPy (on truth and in the SITL configuration, by stage), 1000
        batched drones, flight quality.
world:  1,000 vehicles (4 MAVLink networks, sitl --workers 2) with full default telemetry,
        counted on the wire, CPU used, ArduPilot's process per vehicle (256 at most) as the
        stated peer; 10,000 drones of controller + physics at 400 Hz on one core, CPU per
        drone-step and where the time goes; the default world (drone + rover, autopilots,
        telemetry) unpaced in-process, its cost per vehicle-step by stage.
bridge: latency the bridge adds to a tower goal (vs a direct link), forwarding rate
        with telemetry from 1, 10 and 100 vehicles (vs MAVProxy), bridge on one CPU; the
        added latency again with 1,000 vehicles' telemetry flowing (a fake source, 4 networks).
view:   what the live Foxglove view and run.mcap cost per message, vs writing the tlog.
mission: a 1 km, 10-waypoint AUTO mission's flight time vs the sum of its legs' minimum times.
mission-transfer: 100-item mission upload and download, pymavlink vs MAVSDK.
family: the tower's family of 100 drones end to end in lockstep (wall time, goals, separation).
lockstep: the lab at --speedup max (wall start to summary, achieved speedup, on one core), the
        TICK round trip, sitl's start to its first HEARTBEAT; the previous release beside
        (--peer / TOWERLINK_PEER_TREE).
logs:   onboard DataFlash logs: CPU per armed vehicle-second, logging off vs on.
pytest: the example flight test on the towerlink_sitl fixture vs a hand-rolled subprocess fixture.
"""
from __future__ import annotations

import argparse
import importlib
import time


BENCHES = {
    "frames": "tools.bench_frames",
    "flight": "tools.bench_flight",
    "world": "tools.bench_world",
    "bridge": "tools.bench_bridge",
    "mission": "tools.bench_mission",
    "view": "tools.bench_view",
    "mission-transfer": "tools.bench_mission_transfer",
    "family": "tools.bench_family",
    "lockstep": "tools.bench_lockstep",
    "logs": "tools.bench_logs",
    "pytest": "tools.bench_pytest",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"which benchmarks ({', '.join(BENCHES)}); default all")


def run(args: argparse.Namespace) -> int:
    names = args.names or list(BENCHES)
    unknown = [n for n in names if n not in BENCHES]
    if unknown:
        print(f"towerlink bench: unknown benchmark {unknown[0]!r}; choose from {', '.join(BENCHES)}")
        return 2
    status = 0
    for name in names:
        t0 = time.perf_counter()
        print(f"== {name} ==", flush=True)
        status |= int(importlib.import_module(BENCHES[name]).main([]) or 0)
        print(f"({name}: {time.perf_counter() - t0:.0f} s)\n", flush=True)
    return status
