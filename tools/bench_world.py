"""Benchmark: a world of 100 vehicles (50 drones, 50 rovers) with full MAVLink telemetry
pushed to a UDP sink, at real time (speedup 1): CPU used by the world process.

The world runs as `towerlink sitl` in a child process (so the sink's CPU is not counted);
its CPU seconds come from /proc/PID/stat over a steady-state window after start-up.
Target: < 1 core.  Usage: python -m tools.bench_world [--seconds 10] [--drones 50 --rovers 50]
"""
from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import threading
import time

from tools.benchtable import machine, table, stop_process


def _cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Sink:
    """Counts datagrams/bytes; tracks sysid 1's SYSTEM_TIME.time_boot_ms for the sim clock."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.packets = self.bytes = self.datagrams = 0
        self.sysids: set[int] = set()
        self.boot_ms = 0
        self.running = True
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        import struct
        while self.running:
            try:
                data = self.sock.recv(65536)
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
                self.sysids.add(sysid)
                if sysid == 1 and data[off + 7] == 2 and data[off + 8] == 0 and data[off + 9] == 0:
                    payload = data[off + 10:off + 10 + n].ljust(12, b"\0")   # MAVLink 2 trims zeros
                    self.boot_ms = struct.unpack_from("<I", payload, 8)[0]   # SYSTEM_TIME.time_boot_ms
                off = end

    def close(self) -> None:
        self.running = False
        self.sock.close()


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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_world", description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--drones", type=int, default=50)
    ap.add_argument("--rovers", type=int, default=50)
    a = ap.parse_args(argv)
    sink = Sink()
    cmd = [sys.executable, "-m", "tools.cli", "sitl", "--drones", str(a.drones), "--rovers", str(a.rovers),
           "--speedup", "1", "--no-save", "--tcp-base", "0", "--udp-base", "0",
           "--out", f"udpout:127.0.0.1:{sink.port}"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    n = a.drones + a.rovers
    try:
        end = time.monotonic() + 60
        while len(sink.sysids) < n and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.1)
        time.sleep(1.0)                       # let start-up transients pass
        c0, w0, p0, b0, s0, d0 = (_cpu_seconds(proc.pid), time.monotonic(), sink.packets, sink.bytes,
                                  sink.boot_ms, sink.datagrams)
        time.sleep(a.seconds)
        c1, w1, p1, b1, s1, d1 = (_cpu_seconds(proc.pid), time.monotonic(), sink.packets, sink.bytes,
                                  sink.boot_ms, sink.datagrams)
    finally:
        stop_process(proc)
        sink.close()
    wall = w1 - w0
    cpu = (c1 - c0) / wall
    rt = (s1 - s0) / 1000.0 / wall
    split = _split(a.drones, a.rovers)
    print(machine())
    print(table(f"World of {n} vehicles ({a.drones} drones, {a.rovers} rovers), full MAVLink telemetry to a UDP sink, speedup 1",
                ["measure", "value", "target"],
                [["vehicles seen on the wire", f"{len(sink.sysids)}", f"{n}"],
                 ["wall window (s)", f"{wall:.1f}", ""],
                 ["CPU (process s / wall s)", f"{cpu:.2f} cores", "< 1 core"],
                 ["sim s per wall s", f"{rt:.2f}", "1.00"],
                 ["CPU per sim s (cores at real time)", f"{cpu / max(rt, 1e-9):.2f} cores", "< 1 core"],
                 ["  in-process split, CPU s per sim s: fleets (physics+sensors+estimator+control)", f"{split[0]:.2f} s", ""],
                 ["  in-process split, CPU s per sim s: autopilots + MAVLink telemetry", f"{split[1]:.2f} s", ""],
                 ["messages / s (all vehicles)", f"{(p1 - p0) / wall:.0f}", ""],
                 ["messages / s per vehicle", f"{(p1 - p0) / wall / n:.1f}", ""],
                 ["UDP datagrams / s", f"{(d1 - d0) / wall:.0f}", ""],
                 ["kB / s", f"{(b1 - b0) / wall / 1024:.0f}", ""]]))
    return 0 if len(sink.sysids) == n else 1


if __name__ == "__main__":
    sys.exit(main())
