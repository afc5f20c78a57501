"""The default world in-process: one drone and one rover with their autopilots, telemetry
built and sent on their links (a UDP sink), stepped as fast as the CPU allows (what
`--speedup max` without lockstep does), and what each vehicle-step costs by stage.

  python -m tools.bench_default_world     (also part (c) of `towerlink bench world`)

The drone takes off in GUIDED and flies to a point 20 m away, the rover drives to it; the
timed window starts once both move. Figures: CPU per world step (least of REPEAT windows of
2 sim s, process time),
real-time factor, and the cost per vehicle-step split into physics, control, sensors,
estimator, fleet bookkeeping, autopilot, telemetry and I/O (tools.bench_stages).
"""
from __future__ import annotations

import argparse
import asyncio
import inspect
import math
import os
import socket
import subprocess
import sys
import time

from tools.bench_stages import StageTimer, scalar_form_spots
from tools.benchtable import load_line, machine, table

TARGET = 100.0        # x real time, the default world (issue target)
WORLD = "world (wind, position sharing, clock)"
STAGES = ("physics", "control", "sensors", "estimator", "fleet bookkeeping", "autopilot", "telemetry", "I/O")
ESTIMATOR_PARTS = (("  estimator: filterpy predict + update", "filterpy"),
                   ("  estimator: epoch arithmetic and dead reckoning (AHRS, rotations, outputs)", "epoch"))


def fleet_spots(kind: str, f) -> list[tuple[object, str, str]]:
    """(owner, name, "<kind> <stage>") of what one fleet's step calls: its physics and
    control core, sensors, estimator (the fleet's side, the epoch, filterpy) and the rest
    (the fleet's own bookkeeping). Small fleets call the cores' scalar forms, which call
    each other directly (tools.bench_stages.scalar_form_spots); big ones the modules'."""
    from vehicle import fleet as fl
    from vehicle import fleet_base as fb
    from vehicle.control import copter as cc
    from vehicle.control import rover as rc
    from vehicle.physics import multicopter as mc
    from vehicle.physics import rover as rp
    cores = {"copter": (fl._copter_core, [(mc.step, "physics"), (cc.step, "control"), (cc.relax, "control")]),
             "rover": (fl._rover_drive, [(rc.step, "control")])}[kind]
    caller, callees = cores
    spots = []
    for fn, stage in callees:
        spots.append((sys.modules[fn.__module__], fn.__name__, f"{kind} {stage}"))
        spots += scalar_form_spots(caller, fn, f"{kind} {stage}")
    if kind == "rover":         # the kinematics: called by the fleet itself, every step
        spots.append((rp, "step", "rover physics"))
        if f.scalar:
            spots.append((f, "_kinematics_form", "rover physics"))
    spots.append((f, "step", f"{kind} fleet bookkeeping"))
    for name in ("_sense_and_estimate_scalar", "_sense_and_estimate_vec"):
        spots.append((f, name, f"{kind} estimator"))
    if f.use_estimator:
        for name in ("sample", "sample_rows", "gyro_noise"):
            spots.append((f.sensors, name, f"{kind} sensors"))
        e = f.estimator
        spots += [(e, "epoch", f"{kind} estimator/epoch"), (e, "epoch_rows", f"{kind} estimator/epoch"),
                  (e, "output_step", f"{kind} estimator/epoch"),
                  (fb, "output_step_scalar", f"{kind} estimator/epoch")]
        for kf in e.kfs or ():
            spots += [(kf, "predict", f"{kind} estimator/filterpy"), (kf, "update", f"{kind} estimator/filterpy")]
    return spots


def _spots(w) -> list[tuple[object, str, str]]:
    """fleet_spots of every fleet, the autopilots, links and endpoints, and the world."""
    spots: list[tuple[object, str, str]] = [(w, "step", WORLD)]
    for kind, f in w.fleets:
        spots += fleet_spots(kind, f)
    for v in w.vehicles:
        spots.append((v.ap, "update", f"{v.kind} autopilot"))
        spots.append((v.link, "update", f"{v.kind} telemetry"))
        for ep in v.link.endpoints:
            spots.append((ep, "send", f"{v.kind} I/O"))
    return spots


def least_split(run, spots, steps: int, windows: int = 5) -> tuple[dict[str, float], float]:
    """({label: least self time per step over `windows` runs of run(), each `steps` steps},
    least value run() returned): on a shared machine a descheduled moment lands on whichever
    stage is running, and the least-disturbed window is the cost."""
    best: dict[str, float] = {}
    inst = math.inf
    for _ in range(windows):
        with StageTimer(spots) as st:
            inst = min(inst, run())
        for k, v in st.seconds.items():
            best[k] = min(best.get(k, math.inf), v / steps)
    return best, inst


def by_stage(best: dict[str, float], kinds: tuple[str, ...]) -> tuple[dict, dict]:
    """({stage: per-kind tuple}, {estimator part: per-kind tuple}) from least_split labels;
    the estimator's row includes its parts."""
    split = {stage: tuple(best.get(f"{k} {stage}", 0.0) for k in kinds) for stage in STAGES}
    detail = {name: tuple(best.get(f"{k} estimator/{part}", 0.0) for k in kinds) for name, part in ESTIMATOR_PARTS}
    split["estimator"] = tuple(sum(v) for v in zip(split["estimator"], *detail.values()))
    return split, detail


def _fly(w) -> None:
    """Both vehicles GUIDED, armed and on their way (the drone climbing to 10 m first)."""
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from vehicle.autopilot import modes
    drone, rover = (v.ap for v in w.vehicles)
    while not all(v.ap.est_ok and v.ap.home is not None for v in w.vehicles):
        w.run_for(0.1)
    drone.set_mode(modes.GUIDED)
    rover.set_mode(modes.ROVER_GUIDED)
    for ap in (drone, rover):
        if ap.arm() != mav.MAV_RESULT_ACCEPTED:
            raise RuntimeError(f"{ap.kind} did not arm: {ap.prearm_failures()}")
    drone.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, 10.0])
    w.run_for(5.0)
    pos_only = 0b110111111000
    drone.position_target_local(mav.MAV_FRAME_LOCAL_NED, pos_only, (20.0, 5.0, -10.0), (0, 0, 0), (0, 0, 0), 0, 0)
    rover.position_target_local(mav.MAV_FRAME_LOCAL_NED, pos_only, (20.0, 5.0, 0.0), (0, 0, 0), (0, 0, 0), 0, 0)
    w.run_for(0.5)


def _run_world(seconds: float, repeat: int, then=None):
    """The default world flying (_fly), telemetry sent to a UDP sink; returns (least CPU s
    per world step over `repeat` windows of `seconds` sim s, then(w, timed) or None).
    Uses only the World API the previous release has too: PEER_SCRIPT runs this source there."""
    from vehicle.world import World, WorldConfig
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    sink.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    w = World(WorldConfig(drones=1, rovers=1, state_dir=None, tcp_base=None, udp_base=None,
                          outs=[f"udpout:127.0.0.1:{sink.getsockname()[1]}"]))
    steps = round(seconds / w.dt)

    def timed() -> float:
        t0 = time.process_time()
        for _ in range(steps):
            w.step()
        return (time.process_time() - t0) / steps

    async def go():
        await w.start_endpoints()
        _fly(w)
        per = min(timed() for _ in range(repeat))
        extra = then(w, timed, steps) if then is not None else None
        for v in w.vehicles:
            v.link.close()
        logs = getattr(w, "logs", None)       # the onboard logs' writer thread (a release may have none)
        if logs is not None:
            logs.close()                      # before its folder goes, as World.run does
        return per, extra
    try:
        return asyncio.run(go())
    finally:
        sink.close()


REPEAT = 7            # timed windows: on a shared machine the least-disturbed one is the cost


def measure(seconds: float = 2.0, peer: str | None = None) -> dict:
    """{'per_step': CPU s per world step, 'stages': {stage: (drone s, rover s) per step},
    'instrumented': CPU s per step with the stage timers in, 'vehicles': 2, 'peer': (CPU s
    per step or None, note) of checkout `peer` (default: $TOWERLINK_PEER_TREE)}."""
    def split_stages(w, timed, steps):
        best, inst = least_split(timed, _spots(w), steps)
        split, detail = by_stage(best, ("copter", "rover"))
        split[WORLD] = (best.get(WORLD, 0.0) / 2,) * 2     # shared: half each
        return {"instrumented": inst, "stages": split, "estimator": detail, "dt": w.dt}
    per, m = _run_world(seconds, REPEAT, split_stages)
    return {"per_step": per, "vehicles": 2, **m,
            "peer": peer_per_step(peer or os.environ.get("TOWERLINK_PEER_TREE"), seconds, REPEAT)}


# the peer: the same measurement in another checkout (the previous release), in its own process
PEER_SCRIPT = "\n".join(["import asyncio, socket, sys, time", inspect.getsource(_fly), inspect.getsource(_run_world),
                          "print(_run_world(float(sys.argv[1]), int(sys.argv[2]))[0])"])


def peer_per_step(tree: str | None, seconds: float = 2.0, repeat: int = REPEAT) -> tuple[float | None, str]:
    """(CPU s per world step of the default world in checkout `tree`, note); None when there
    is no such checkout (TOWERLINK_PEER_TREE or --peer: a worktree of the previous release)."""
    if not tree or not os.path.isdir(os.path.join(tree, "vehicle")):
        return None, "no peer checkout (--peer DIR or TOWERLINK_PEER_TREE)"
    env = dict(os.environ, PYTHONPATH=tree)
    r = subprocess.run([sys.executable, "-c", PEER_SCRIPT, str(seconds), str(repeat)], cwd=tree, env=env,
                       capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        return None, f"peer failed: {r.stderr.strip().splitlines()[-1:]}"
    rev = subprocess.run(["git", "-C", tree, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return float(r.stdout.split()[-1]), f"{tree} at {rev.stdout.strip() or '?'}"


def stage_rows(split: dict, detail: dict) -> list[list[str]]:
    """Table rows from by_stage: each stage in us per step (a column per kind, then their
    mean when there are several) and its share; under the estimator its parts."""
    cols = len(next(iter(split.values())))
    tot = sum(sum(v) for v in split.values()) or 1.0

    def row(name, vals, share=True):
        mean = [f"{sum(vals) / cols * 1e6:.2f}"] if cols > 1 else []
        return [name, *(f"{x * 1e6:.2f}" for x in vals), *mean, f"{100 * sum(vals) / tot:.0f} %" if share else ""]
    rows = []
    for stage, vals in split.items():
        rows.append(row(stage, vals))
        if stage == "estimator":
            rows += [row(name, part) for name, part in detail.items()]
            rest = tuple(v - sum(p[j] for p in detail.values()) for j, v in enumerate(vals))
            rows.append(row("  estimator: the fleet's side (truth rows in, estimate rows out)", rest))
    rows.append(row("total (instrumented: each timer adds ~0.5 us a call)",
                    tuple(sum(v[j] for v in split.values()) for j in range(cols)), share=False))
    return rows


def _peer_rows(peer: tuple[float | None, str], per: float, dt: float) -> list[list[str]]:
    ps, note = peer
    if ps is None:
        return [["peer: the previous release of towerlink", note, "", "not run"]]
    return [[f"peer: the previous release ({note}), CPU per world step (us)", f"{ps * 1e6:.1f}", "", "-"],
            ["peer: real-time factor", f"{dt / ps:.1f}x", "", "-"],
            ["this tree / the previous release (speed)", f"{ps / per:.2f}x", "", "-"]]


def report(m: dict) -> tuple[str, bool]:
    per, dt = m["per_step"], m["dt"]
    rtf = dt / per
    head = table("(c) the default world in-process (1 drone + 1 rover, autopilots, telemetry sent to a UDP sink), "
                 "unpaced, no lockstep, one core",
                 ["measure", "value", "target", "status"],
                 [[f"CPU per world step (us, least of {REPEAT})", f"{per * 1e6:.1f}",
                   f"<= {dt / TARGET * 1e6:.0f}", "-"],
                  ["CPU per vehicle-step (us)", f"{per * 1e6 / m['vehicles']:.1f}", "", "-"],
                  ["real-time factor", f"{rtf:.1f}x", f">= {TARGET:.0f}x", "met" if rtf >= TARGET else "MISSED"],
                  *_peer_rows(m["peer"], per, dt)])
    rows = stage_rows(m["stages"], m["estimator"])
    split = table("(c) cost per vehicle-step by stage (us per 400 Hz step; autopilot and telemetry run at 50 Hz, "
                  "averaged over the steps)", ["stage", "drone", "rover", "per vehicle-step", "share"], rows)
    return head + "\n\n" + split, rtf >= TARGET


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="the default world in-process, by stage, beside a peer checkout")
    ap.add_argument("--peer", help="a checkout of the previous release to measure side by side "
                                   "(default: $TOWERLINK_PEER_TREE)")
    a = ap.parse_args(argv)
    print(f"machine: {machine()}", flush=True)
    print(f"{load_line()} at start; process CPU time, so time other processes take is not counted", flush=True)
    text, ok = report(measure(peer=a.peer))
    print(text)
    print(f"{load_line()} at the end")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
