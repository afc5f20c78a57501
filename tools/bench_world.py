"""Benchmark: a big SITL world on the wire, 10,000 drones of physics and control, and the
default world in-process.

  python -m tools.bench_world            (or: towerlink bench world)

(a) A world of 1,000 vehicles (500 drones, 500 rovers) with full default MAVLink telemetry,
    `towerlink sitl --speedup 1` in a child process pushing every network to its own UDP
    sink port (--out P, network g on P+g; vehicle/network_plan.py). Counted on the wire:
    distinct (network, sysid) pairs, and packets arriving on the wrong network's port.
    CPU of the world process from /proc/PID/stat over a steady window; sim seconds per
    wall second from network 0 / sysid 1's SYSTEM_TIME; an in-process, unpaced split of
    CPU per sim second between the fleets and the autopilots + telemetry.
    Onboard logging is on, with ArduPilot's defaults (a log opens at arming): nothing arms
    here, so no log is written; `towerlink bench logs` gives an armed vehicle's cost.
    Peer (stated, not run): ArduPilot SITL runs one process per vehicle and stops at 256
    instances (PX4's multi-vehicle scripts at 254), each with its own ports.
(b) 10,000 drones (CopterFleet on truth: controller + physics, no sensors) stepped at
    400 Hz on one core: CPU per fleet step (best of 5, process time, so other processes on
    a shared machine count less), cost per drone-step, real-time factor, and where the
    time goes (per stage, and the costliest source lines from a line trace).
(c) The default world (1 drone + 1 rover, autopilots, telemetry sent on their links) stepped
    unpaced in-process: real-time factor and the cost per vehicle-step by stage
    (tools.bench_default_world).
"""
from __future__ import annotations

import argparse
import collections
import linecache
import math
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

from tools import bench_default_world
from tools.bench_stages import StageTimer
from tools.benchtable import machine, table

DT = 1.0 / 400.0


def _cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) of process `pid` and all its descendants (--workers)."""
    stats = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            stats[int(d)] = (int(fields[1]), int(fields[11]) + int(fields[12]))   # ppid, ticks
    tree, frontier = {pid}, [pid]
    while frontier:
        parent = frontier.pop()
        for child, (ppid, _) in stats.items():
            if ppid == parent and child not in tree:
                tree.add(child)
                frontier.append(child)
    return sum(stats[p][1] for p in tree if p in stats) / os.sysconf("SC_CLK_TCK")


class Sink:
    """UDP listeners on `groups` consecutive ports (network g on base + g). Counts datagrams,
    frames, bytes, the (network, sysid) pairs seen, and frames from a sysid that network does
    not hold (`misrouted`); keeps each vehicle's first and latest SYSTEM_TIME in `window`."""

    def __init__(self, groups: int, expected: list[set[int]]) -> None:
        self.socks = self._bind(groups)
        self.port = self.socks[0].getsockname()[1]
        self.expected = expected
        self.packets = self.bytes = self.datagrams = self.misrouted = 0
        self.seen: set[tuple[int, int]] = set()
        # (network, sysid) -> [(wall s, SYSTEM_TIME.time_boot_ms) of the first and the latest]
        self.clock: dict[tuple[int, int], list[tuple[float, int]]] = {}
        self.window: tuple[float, float] | None = None      # wall span the rates are taken over
        self.running = True
        self.threads = [threading.Thread(target=self._run, args=(g, s), daemon=True)
                        for g, s in enumerate(self.socks)]
        for t in self.threads:
            t.start()

    @staticmethod
    def _bind(groups: int) -> list[socket.socket]:
        for _ in range(50):                       # a run of free consecutive ports
            first = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            first.bind(("127.0.0.1", 0))
            socks = [first]
            try:
                for g in range(1, groups):
                    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                    socks.append(s)
                    s.bind(("127.0.0.1", first.getsockname()[1] + g))
            except OSError:
                for s in socks:
                    s.close()
                continue
            for s in socks:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
                s.settimeout(0.2)
            return socks
        raise RuntimeError(f"no {groups} consecutive free UDP ports")

    def _run(self, g: int, sock: socket.socket) -> None:
        mine = self.expected[g]
        while self.running:
            try:
                data = sock.recv(65536)
            except socket.timeout:
                continue
            except OSError:
                return
            self.datagrams += 1
            self.bytes += len(data)
            off = 0
            while off + 12 <= len(data) and data[off] == 253:     # several frames per datagram
                n = data[off + 1]
                end = off + 12 + n + (13 if data[off + 2] & 1 else 0)
                self.packets += 1
                sysid = data[off + 5]
                if sysid in mine:
                    self.seen.add((g, sysid))
                else:
                    self.misrouted += 1
                if data[off + 7] == 2 and data[off + 8] == 0 and data[off + 9] == 0:   # SYSTEM_TIME
                    payload = data[off + 10:off + 10 + n].ljust(12, b"\0")   # MAVLink 2 trims zeros
                    now = time.monotonic()
                    w = self.window
                    if w is not None and w[0] <= now <= w[1]:
                        mark = (now, struct.unpack_from("<I", payload, 8)[0])
                        c = self.clock.setdefault((g, sysid), [mark, mark])
                        c[1] = mark
                off = end

    def close(self) -> None:
        self.running = False
        for s in self.socks:
            s.close()


def _split(drones: int, rovers: int, seconds: float = 2.0) -> tuple[float, float]:
    """In-process, unpaced: CPU s per sim s spent in the fleets vs the autopilots+links."""
    import asyncio
    from vehicle.world import World, WorldConfig
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.bind(("127.0.0.1", 0))
    w = World(WorldConfig(drones=drones, rovers=rovers, state_dir=None, tcp_base=None, udp_base=None,
                          outs=[f"udpout:127.0.0.1:{sink.getsockname()[1]}"]))

    async def go():
        await w.start_endpoints()
        w.run_for(1.0)
        fleet_t = rest_t = 0.0
        for _ in range(int(seconds / w.dt)):
            t0 = time.process_time()
            for _, f in w.fleets:
                f.step(w.dt)
            t1 = time.process_time()
            w.steps += 1
            w.t = w.steps * w.dt
            if w.steps % w.ap_every == 0:
                for v in w.vehicles:
                    v.ap.update(w.t)
                    v.link.update(w.t)
            rest_t += time.process_time() - t1
            fleet_t += t1 - t0
        for v in w.vehicles:
            v.link.close()
        return fleet_t / seconds, rest_t / seconds
    try:
        return asyncio.run(go())
    finally:
        sink.close()


def world_bench(drones: int, rovers: int, seconds: float, workers: int = 2) -> tuple[str, bool]:
    from vehicle.network_plan import plan
    n = drones + rovers
    p = plan(drones, rovers, tcp_base=None, udp_base=None)
    expected = [{v.sysid for v in p.vehicles[g.first:g.last + 1]} for g in p.groups]
    sink = Sink(len(p.groups), expected)
    plan_file = os.path.join(tempfile.mkdtemp(prefix="bench_world"), "plan.json")
    cmd = [sys.executable, "-m", "tools.cli", "sitl", "--drones", str(drones), "--rovers", str(rovers),
           "--speedup", "1", "--no-save", "--tcp-base", "0", "--udp-base", "0",
           "--out", f"udpout:127.0.0.1:{sink.port}", "--plan-out", plan_file, "--workers", str(workers)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    t_start = time.monotonic()
    try:
        end = time.monotonic() + 90
        while len(sink.seen) < n and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.1)
        t_all = time.monotonic() - t_start
        time.sleep(1.0)                       # let start-up transients pass
        c0, w0, p0, b0, d0 = _cpu_seconds(proc.pid), time.monotonic(), sink.packets, sink.bytes, sink.datagrams
        sink.window = (w0, w0 + seconds)
        time.sleep(seconds)
        c1, w1, p1, b1, d1 = _cpu_seconds(proc.pid), time.monotonic(), sink.packets, sink.bytes, sink.datagrams
    finally:
        proc.terminate()
        try:
            _, err = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
        sink.close()
    if proc.returncode not in (0, -15):
        print(f"world process ended with {proc.returncode}: {err[-2000:]}")
    wall = w1 - w0
    cpu = (c1 - c0) / wall
    # sim s per wall s of every vehicle whose SYSTEM_TIMEs in the window span >= 40 % of it
    # (SYSTEM_TIME streams at a few Hz of sim time: a slow world sends few); the slowest counts
    rts = sorted((b[1] - a[1]) / 1000.0 / (b[0] - a[0]) for a, b in sink.clock.values()
                 if b[0] - a[0] >= 0.4 * seconds)
    rt = rts[0] if rts else 0.0
    rt_med = rts[len(rts) // 2] if rts else 0.0
    fleets, rest = _split(drones, rovers)
    seen = len(sink.seen)
    rows = [["vehicles seen on the wire (network, sysid)", f"{seen}", f"{n}", "met" if seen == n else "MISSED"],
            ["networks (one --out port each)", f"{len(p.groups)}", f"ceil({n}/254)", "-"],
            ["packets on another network's port", f"{sink.misrouted}", "0", "met" if sink.misrouted == 0 else "MISSED"],
            ["time until every vehicle was heard (s)", f"{t_all:.1f}", "", "-"],
            ["wall window (s)", f"{wall:.1f}", "", "-"],
            ["CPU of the world processes (process s / wall s)", f"{cpu:.2f} cores", "<= 2 cores",
             "met" if cpu <= 2.0 else "MISSED"],
            ["world processes (--workers)", f"{workers}", "<= 2 cores", "-"],
            ["sim s per wall s, slowest vehicle (SYSTEM_TIME)", f"{rt:.2f}", "1.00", "met" if rt >= 0.995 else "MISSED"],   # a paced 100-vehicle world reads 1.00
            ["sim s per wall s, median vehicle", f"{rt_med:.2f}", "", "-"],
            ["vehicles with a measurable sim clock in the window", f"{len(rts)}", f"{n}", "-"],
            ["CPU per sim s (cores needed at real time)",
             f"{cpu / rt_med:.2f} cores" if rt_med > 0 else "not measurable", "<= 2 cores",
             "met" if rt_med > 0 and cpu / rt_med <= 2.0 else "MISSED"],
            ["  in-process split, CPU s per sim s: fleets (physics+sensors+estimator+control)", f"{fleets:.2f} s", "", "-"],
            ["  in-process split, CPU s per sim s: autopilots + MAVLink telemetry", f"{rest:.2f} s", "", "-"],
            ["messages / s (all vehicles)", f"{(p1 - p0) / wall:.0f}", "", "-"],
            ["messages / s per vehicle", f"{(p1 - p0) / wall / n:.1f}", "", "-"],
            ["UDP datagrams / s", f"{(d1 - d0) / wall:.0f}", "", "-"],
            ["kB / s", f"{(b1 - b0) / wall / 1024:.0f}", "", "-"],
            ["onboard logs (vehicle/logs/)", "on, none written", "", "-"],   # default LOG_*: a log opens at arming; nothing arms here
            ["peer: ArduPilot SITL (stated, not run)", "1 process per vehicle", "at most 256 instances", "-"]]
    ok = seen == n and sink.misrouted == 0
    return table(f"(a) World of {n} vehicles ({drones} drones, {rovers} rovers), full default MAVLink telemetry "
                 f"to one UDP sink port per network, speedup 1", ["measure", "value", "target", "status"], rows), ok


def _fleet(n: int):
    from tools.bench_flight import airborne_fleet
    return airborne_fleet(n, side=int(math.ceil(math.sqrt(n))))


def _cpu_per_step(f, steps: int = 200, repeat: int = 5) -> tuple[float, float]:
    """(best CPU s, best wall s) per fleet step."""
    cpu = wall = math.inf
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        for _ in range(steps):
            f.step(DT)
        cpu = min(cpu, (time.process_time() - c0) / steps)
        wall = min(wall, (time.perf_counter() - w0) / steps)
    return cpu, wall


def _stages(f, steps: int = 100) -> list[tuple[str, float]]:
    """CPU s per step in each stage of the copter step (self times, tools.bench_stages)."""
    from vehicle import fleet as fl
    from vehicle.control import copter as cc
    from vehicle.control import shaping
    from vehicle.physics import multicopter as mc
    spots = [(shaping, "shape_xy", "reference shaping, horizontal (shaping.shape_xy)"),
             (shaping, "shape_z", "reference shaping, vertical (shaping.shape_z)"),
             (cc, "step", "position/velocity/attitude/rate loops (control.copter.step)"),
             (cc, "mix", "mixer (control.copter.mix)"),
             (mc, "step", "rigid body + motors (physics.multicopter.step)"),
             (fl, "_land_detect", "land detector (fleet._land_detect)")]
    with StageTimer(spots, limit=math.inf, clock=time.process_time) as st:
        t0 = time.process_time()
        for _ in range(steps):
            f.step(DT)
        total = (time.process_time() - t0) / steps
    out = [(label, st.seconds.get(label, 0.0) / steps) for _, _, label in spots]
    out.append(("fleet bookkeeping (masks, idle/arm selection)", total - sum(v for _, v in out)))
    return out


def _lines(f, steps: int = 100, top: int = 10) -> list[tuple[str, float]]:
    """The costliest source lines of the step (sys.settrace line timing: absolute times carry
    the tracer's overhead, the shares are what to read)."""
    files = ("control/copter.py", "control/shaping.py", "physics/multicopter.py", "vehicle/fleet.py",
             "physics/__init__.py")
    acc: dict[tuple, float] = collections.Counter()
    prev: list = [None, 0.0]

    def local(frame, event, arg):
        now = time.perf_counter()
        if prev[0] is not None:
            acc[prev[0]] += now - prev[1]
        prev[0] = (frame.f_code.co_filename, frame.f_lineno) if event == "line" else None
        prev[1] = time.perf_counter()
        return local

    def tracer(frame, event, arg):
        return local if frame.f_code.co_filename.endswith(files) else None
    sys.settrace(tracer)
    try:
        for _ in range(steps):
            f.step(DT)
    finally:
        sys.settrace(None)
    total = sum(acc.values())
    rows = []
    for (fn, ln), v in acc.most_common(top):
        src = linecache.getline(fn, ln).strip()
        rows.append((f"{fn.split('vehicle/')[-1]}:{ln}  {src[:70]}", v / total))
    return rows


def physics_bench(n: int) -> tuple[str, bool]:
    f = _fleet(n)
    cpu, wall = _cpu_per_step(f)
    rtf = DT / cpu
    out = [table(f"(b) {n} drones, controller + physics on truth, 400 Hz, one core",
                 ["measure", "value", "target", "status"],
                 [["CPU per fleet step (ms, best of 5 x 200 steps)", f"{cpu * 1e3:.3f}", f"<= {DT * 1e3:.1f}", "-"],
                  ["CPU per drone-step (us)", f"{cpu * 1e6 / n:.3f}", "", "-"],
                  ["real-time factor (CPU)", f"{rtf:.2f}x", ">= 1x", "met" if rtf >= 1.0 else "MISSED"],
                  ["real-time factor (wall, best run)", f"{DT / wall:.2f}x", "", "-"],
                  ["RotorPy batched (torch), DESIGN.md figure", "48 us per drone-step", "(not run here)", "-"]])]
    stages = _stages(f)
    tot = sum(v for _, v in stages)
    out.append(table(f"(b) where the time goes, {n} drones: CPU per step by stage",
                     ["stage", "ms per step", "share"],
                     [[k, f"{v * 1e3:.3f}", f"{100 * v / tot:.0f} %"] for k, v in stages]))
    out.append(table(f"(b) costliest source lines, {n} drones (line trace; shares of traced time)",
                     ["line", "share"], [[k, f"{100 * v:.1f} %"] for k, v in _lines(f)]))
    return "\n\n".join(out), rtf >= 1.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_world", description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="steady window of the world run (default 10)")
    ap.add_argument("--drones", type=int, default=500, help="drones in the world (default 500)")
    ap.add_argument("--rovers", type=int, default=500, help="rovers in the world (default 500)")
    ap.add_argument("--physics-drones", type=int, default=10000, metavar="N",
                    help="drones in the physics/control benchmark (default 10000)")
    ap.add_argument("--workers", type=int, default=2, help="world processes (sitl --workers; default 2)")
    ap.add_argument("--only", choices=("world", "physics", "default"), help="run one part")
    a = ap.parse_args(argv)
    print(f"{machine()} | load average {os.getloadavg()[0]:.1f} (other processes share these cores)", flush=True)
    ok = True
    if a.only in (None, "world"):
        text, good = world_bench(a.drones, a.rovers, a.seconds, a.workers)
        print(text, flush=True)
        print()
        ok &= good
    if a.only in (None, "physics"):
        text, good = physics_bench(a.physics_drones)
        print(text, flush=True)
        print()
    if a.only in (None, "default"):
        text, _ = bench_default_world.report(bench_default_world.measure())
        print(text, flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
