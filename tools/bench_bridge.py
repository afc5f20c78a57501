"""Benchmark the bridge as a process (`towerlink bridge`, pinned to one CPU) between fake
endpoints on loopback UDP sockets this benchmark owns.

Rows:
  * added latency: a tower goal (SET_POSITION_TARGET_LOCAL_NED, LOCAL_NED, translated
    tower -> world by the bridge) from the moment it leaves the tower's socket to the
    moment the drone's socket returns it, p50 and p99, against a direct link (the same
    datagrams sent straight to the drone's socket), the two interleaved one by one in
    the same run so both see the same machine load. Added = bridge - direct.
  * forwarding rate: telemetry from 1, 10 and 100 vehicles sent as fast as one sender
    can into the bridge's drone link; messages per second that reach the tower's socket
    (the bridge's own messages not counted), with the bridge's CPU use. Sysid 1 is the
    drone (LOCAL_POSITION_NED and ATTITUDE_QUATERNION decoded, put in the frame buffer
    and translated to the tower frame); the other sysids are systems behind the same
    link, forwarded as received (the bridge has a drone and a rover link, as
    mavlink-router chains further systems). Peer: MAVProxy as a router
    (--master udpin --out udpout), pinned to the same CPU, fed the same traffic.
    Other processes may share that CPU: the bridge's CPU use is shown, and what one
    CPU-second of it forwards (rate / CPU use), each row judged against the target.
  * the time the bridge was runnable but waiting for its CPU (/proc/PID/schedstat),
    per goal, and the load average: what a p99 on a shared machine is made of.

  * added latency with 1,000 vehicles' telemetry flowing (tools.bench_bridge_fleet: a fake
    source replays ArduPilot's default streams of 1,000 vehicles in 4 networks, 66,000 msg/s),
    bridge and MAVProxy under the same load, each with its CPU use and forwarded rate.

Targets: added p99 <= 1 ms on loopback; >= 20,000 messages/s forwarded on one core.
Usage: python -m tools.bench_bridge [--quick] [--samples N] [--seconds S]
"""
from __future__ import annotations

import argparse
import os
import socket
import sys
import tempfile
import threading
import time
from contextlib import contextmanager

from common.ports import free_port
from common.mavlink.dialect import towerlink as tl
from tools.bench_bridge_probe import (ADDED_P99_TARGET_MS, bridge_args, cpu_seconds, first_heartbeat_from,
                                      hello_tower, latency, mavproxy_exe, mavproxy_router_args, messages_in,
                                      percentile, pinned_process, place_drone, split_cpus, udp_socket)
from tools.benchtable import machine, table

RATE_TARGET = 20_000.0


@contextmanager
def _bridge(cpu: int):
    """A `towerlink bridge` process between a tower socket and a drone socket.

    Yields (proc, tower socket, drone socket, address of the bridge's drone link,
    address of its tower link)."""
    tower, drone = udp_socket(), udp_socket()
    tport = free_port()
    args = bridge_args(tport, "--drone", f"udpout:127.0.0.1:{drone.getsockname()[1]}", "--rover", "none")
    try:
        with pinned_process(args, cpu) as proc:
            link_addr = first_heartbeat_from(drone, proc)
            place_drone(drone, link_addr)
            hello_tower(tower, ("127.0.0.1", tport), proc)
            yield proc, tower, drone, link_addr, ("127.0.0.1", tport)
    finally:
        tower.close()
        drone.close()


# ----------------------------------------------------------------------------- rate

def _telemetry(n_vehicles: int, messages: int) -> list[bytes]:
    """About `messages` datagrams of one message each: rounds of 8 messages per vehicle.

    The drone's (sysid 1) LOCAL_POSITION_NED and ATTITUDE_QUATERNION carry a
    time_boot_ms 10 ms later each round, so the frame buffer takes every one; everything
    else is the same bytes every round (the bridge forwards it undecoded). Sent round and
    round, the drone's clock jumps back once per pass (seen as a reboot), so a pass holds
    enough messages for a measuring window at the rates seen (>= 1 s at 200,000 /s)."""
    others = []
    for sysid in range(2, n_vehicles + 1):
        m = tl.MAVLink(None, sysid, 1)
        others += [bytes(x.pack(m)) for x in _vehicle_msgs(1000, sysid)]
    m1 = tl.MAVLink(None, 1, 1)
    fixed = [bytes(x.pack(m1)) for x in _vehicle_msgs(1000, 1)[2:]]
    out: list[bytes] = []
    for r in range(max(1, messages // (8 * n_vehicles))):
        out += [bytes(x.pack(m1)) for x in _stamped_msgs(1000 + 10 * r)]
        out += fixed
        out += others
    return out


def _stamped_msgs(ms: int) -> list:
    """The two messages the bridge turns into the drone's frames, at time_boot_ms `ms`."""
    return [tl.MAVLink_local_position_ned_message(ms, 0.001 * ms, 2.0, -9.0, 1.0, 0.0, 0.0),
            tl.MAVLink_attitude_quaternion_message(ms, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)]


def _vehicle_msgs(ms: int, sysid: int) -> list:
    """A vehicle's telemetry round: 8 common telemetry messages, one of each."""
    return _stamped_msgs(ms) + [
            tl.MAVLink_heartbeat_message(tl.MAV_TYPE_QUADROTOR, tl.MAV_AUTOPILOT_ARDUPILOTMEGA, 217, 4, 4, 3),
            tl.MAVLink_attitude_message(ms, 0.01, 0.02, 0.3, 0.0, 0.0, 0.0),
            tl.MAVLink_global_position_int_message(ms, 473977420 + sysid, 85455940, 600000, 9000, 100, 0, 0, 3000),
            tl.MAVLink_vfr_hud_message(1.0, 1.0, 30, 50, 9.0, 0.0),
            tl.MAVLink_sys_status_message(1, 1, 1, 500, 12000, -1, 90, 0, 0, 0, 0, 0, 0),
            tl.MAVLink_gps_raw_int_message(ms * 1000, 3, 473977420, 85455940, 600000, 100, 100, 100, 0, 12)]


class _Sink(threading.Thread):
    """Counts the packets arriving at a socket, other than the bridge's own."""

    def __init__(self, sock: socket.socket) -> None:
        super().__init__(daemon=True)
        self.sock, self.count, self.running = sock, 0, True
        sock.settimeout(0.1)
        self.start()

    def run(self) -> None:
        while self.running:
            try:
                data = self.sock.recv(65535)
            except socket.timeout:
                continue
            except OSError:
                return
            self.count += messages_in(data)


def _sender(dest: tuple, frames: list[bytes], stop, sent) -> None:
    """Send `frames` round and round until `stop` (runs in a child process: no GIL shared)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    n = 0
    try:
        while not stop.is_set():
            for i in range(0, len(frames), 500):
                for f in frames[i:i + 500]:
                    s.sendto(f, dest)
                n += len(frames[i:i + 500])
                sent.value = n
    finally:
        s.close()


def _measure_rate(proc, dest, sink_sock, frames, seconds: float) -> tuple[float, float, float]:
    """(forwarded msg/s, offered msg/s, process CPU in cores) over `seconds` of steady state."""
    import multiprocessing as mp
    ctx = mp.get_context("fork")
    sink = _Sink(sink_sock)
    stop, sent = ctx.Event(), ctx.Value("q", 0, lock=False)
    sender = ctx.Process(target=_sender, args=(dest, frames, stop, sent), daemon=True)
    sender.start()
    try:
        time.sleep(min(1.0, seconds / 2))       # benchmark warm-up, not a test wait
        c0, w0, n0, s0 = cpu_seconds(proc.pid), time.perf_counter(), sink.count, sent.value
        time.sleep(seconds)
        c1, w1, n1, s1 = cpu_seconds(proc.pid), time.perf_counter(), sink.count, sent.value
    finally:
        stop.set()
        sender.join(5)
        if sender.is_alive():
            sender.kill()
            sender.join()
        sink.running = False
        sink.join(2)
    wall = w1 - w0
    return (n1 - n0) / wall, (s1 - s0) / wall, (c1 - c0) / wall


def bridge_rate(bridge: tuple, frames: list[bytes], seconds: float) -> tuple[float, float, float]:
    proc, tower, _drone, link_addr, _t = bridge
    return _measure_rate(proc, link_addr, tower, frames, seconds)


def mavproxy_rate(frames: list[bytes], seconds: float, cpu: int) -> tuple[float, float, float] | None:
    """The same traffic through MAVProxy (--master udpin, --out udpout); None if absent."""
    if mavproxy_exe() is None:
        return None
    sink = udp_socket()
    mport = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        args = mavproxy_router_args(mport, sink.getsockname()[1], tmp)
        try:
            with pinned_process(args, cpu, cwd=tmp) as proc:
                probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sink.settimeout(0.2)
                deadline = time.monotonic() + 30.0
                while True:                                # until MAVProxy forwards
                    probe.sendto(frames[0], ("127.0.0.1", mport))
                    try:
                        sink.recv(65535)
                        break
                    except socket.timeout:
                        if time.monotonic() > deadline or proc.poll() is not None:
                            return None
                probe.close()
                return _measure_rate(proc, ("127.0.0.1", mport), sink, frames, seconds)
        finally:
            sink.close()


# ----------------------------------------------------------------------------- report

def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_bridge", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="a smoke run of a few seconds")
    ap.add_argument("--samples", type=int, default=None, help="latency samples per link (default 5000)")
    ap.add_argument("--seconds", type=float, default=None, help="measuring window per rate row (default 5)")
    ap.add_argument("--vehicles", type=int, nargs="+", default=[1, 10, 100], metavar="N",
                    help="telemetry from N vehicles, one rate row each (default 1 10 100)")
    ap.add_argument("--no-peer", action="store_true", help="skip the MAVProxy rate rows")
    ap.add_argument("--fleet-samples", type=int, default=None,
                    help="latency samples with 1,000 vehicles' telemetry flowing (tools.bench_bridge_fleet; "
                         "default 2000, --quick 100; 0 skips the case)")
    a = ap.parse_args(argv)
    fleet_samples = a.fleet_samples if a.fleet_samples is not None else (100 if a.quick else 2000)
    samples = a.samples or (300 if a.quick else 5000)
    seconds = a.seconds or (0.5 if a.quick else 5.0)
    cpu, mine = split_cpus()
    old = os.sched_getaffinity(0)
    os.sched_setaffinity(0, mine)
    try:
        traffic = {n: _telemetry(n, 20_000 if a.quick else int(200_000 * max(1.0, seconds)))
                   for n in a.vehicles}
        with _bridge(cpu) as bridge:            # one bridge process for every row, rows in turn
            lat = latency(bridge, samples)
            rates = [(n, bridge_rate(bridge, traffic[n], seconds)) for n in a.vehicles]
        rates = [(n, r, None if a.no_peer else mavproxy_rate(traffic[n], seconds, cpu))
                 for n, r in rates]
        fleet_rows = []
        if fleet_samples > 0:
            from tools.bench_bridge_fleet import rows as fleet
            fleet_rows, _raw = fleet(cpu, fleet_samples, peer=not a.no_peer)
    finally:
        os.sched_setaffinity(0, old)
    b, d = lat["bridge"], lat["direct"]
    rows = []
    for q in (50, 99):
        pb, pd = percentile(b, q) * 1e3, percentile(d, q) * 1e3
        added = pb - pd
        rows.append([f"goal tower -> drone socket, p{q}", f"{pb:.3f} ms", "direct UDP link, same datagrams",
                     f"{pd:.3f} ms", f"{pb / pd:.1f}x", "", ""])
        rows.append([f"  added by the bridge, p{q}", f"{added:.3f} ms", "", "", "",
                     f"<= {ADDED_P99_TARGET_MS:g} ms" if q == 99 else "",
                     ("met" if added <= ADDED_P99_TARGET_MS else "MISSED") if q == 99 else ""])
    rows.append(["  bridge runnable but waiting for its CPU, mean per goal", f"{lat['wait'][0] / max(len(b), 1) * 1e3:.3f} ms",
                 "", "", "", "", ""])
    rows.append(["  samples (lost: bridge, direct)", f"{len(b)} ({lat['lost'][0]})", "", f"{len(d)} ({lat['lost'][1]})",
                 "", "", ""])
    for n, (fwd, offered, cpu_use), peer in rates:
        pcell, ratio = ("-", "-") if peer is None else (f"{peer[0]:,.0f} /s ({peer[2]:.2f} cores)",
                                                         f"{fwd / max(peer[0], 1e-9):.1f}x")
        rows.append([f"forwarded msg/s, telemetry from {n} vehicle{'s' if n > 1 else ''}",
                     f"{fwd:,.0f} /s", "MAVProxy router, same CPU" if peer else "-", pcell, ratio,
                     f">= {RATE_TARGET:,.0f} /s", "met" if fwd >= RATE_TARGET else "MISSED"])
        per_cpu = fwd / max(cpu_use, 1e-9)
        prow = "-" if peer is None else f"{peer[0] / max(peer[2], 1e-9):,.0f}"
        rows.append(["  offered; bridge CPU", f"{offered:,.0f} /s; {cpu_use:.2f} cores", "", "", "", "", ""])
        # what one core would forward were it the bridge's alone (CPU shared with others)
        rows.append(["  forwarded per CPU-second of the bridge", f"{per_cpu:,.0f}", "MAVProxy, same measure" if peer
                     else "-", prow, "-" if peer is None else f"{per_cpu / max(float(prow.replace(',', '')), 1e-9):.1f}x",
                     f">= {RATE_TARGET:,.0f}", "met" if per_cpu >= RATE_TARGET else "MISSED"])
    rows += fleet_rows
    print(machine())
    print(f"bridge pinned to CPU {cpu}; this process on CPUs {sorted(mine)}; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at the end (other processes share these CPUs)")
    print(table("towerlink bridge (a `towerlink bridge` process) vs direct link and MAVProxy, loopback UDP",
                ["measure", "towerlink", "peer", "peer figure", "ratio", "target", "status"], rows))
    if fleet_rows:
        from tools.bench_bridge_fleet import SOURCE_NOTE
        print(SOURCE_NOTE)
    return 0 if b and all(r[1][0] > 0 for r in rates) else 1


if __name__ == "__main__":
    sys.exit(main())
