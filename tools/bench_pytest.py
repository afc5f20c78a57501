"""Benchmark: the example flight test (examples/pytest/test_pymavlink_flight.py: a pymavlink
script arms, takes off to 10 m, flies 50 m north and lands) on towerlink's ``towerlink_sitl``
fixture, against the same script on a hand-rolled subprocess fixture (the peer: what a test
had to write before the plugin).

The peer picks a free port, starts ``towerlink sitl --speedup max`` as a child process,
retries the TCP connection every 0.1 s until the socket exists, waits for the first heartbeat
and then for the estimator (SYS_STATUS pre-arm bit) before the script arms, waits on the
vehicle's telemetry, and stops the process. The fixture runs the world on a thread of the
test's process, warmed up before it yields, and the test waits on the vehicle's truth.

Figures are wall seconds, median of --repeat: the whole test (set-up, flight, tear-down) and
the first heartbeat after the world was started (the fixture's start() / the peer's Popen).
The machine is shared: its load average is printed with the figures.
Usage: python -m tools.bench_pytest [--repeat 3]   (towerlink bench pytest)
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common.ports import free_port
from tools.benchtable import machine, stop_process, table
from tools.sitl_fixture import TowerlinkSitl
from tools.sitl_spec import make_spec

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "pytest" / "test_pymavlink_flight.py"


def example():
    """The example test module (its script and its test function)."""
    spec = importlib.util.spec_from_file_location("pymavlink_flight_example", EXAMPLE)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ----- the plugin's fixture ------------------------------------------------------------------
def fixture_test(ex, workdir: Path) -> float:
    """Wall s of the example test as pytest runs it: fixture set-up, the test, tear-down."""
    t0 = time.perf_counter()
    sitl = TowerlinkSitl(make_spec({"drones": 1, "speedup": "max"}), workdir).start()
    try:
        ex.test_takeoff_fly_50m_north_land(sitl)
    finally:
        sitl.stop()
    return time.perf_counter() - t0


def fixture_heartbeat(workdir: Path) -> float:
    """Wall s from the fixture starting the world to the script's first heartbeat."""
    from pymavlink import mavutil
    t0 = time.perf_counter()
    sitl = TowerlinkSitl(make_spec({"drones": 1}), workdir).start()
    try:
        m = mavutil.mavlink_connection(sitl.connection(0), source_system=255)
        assert m.wait_heartbeat(timeout=10) is not None
        dt = time.perf_counter() - t0
        m.close()
    finally:
        sitl.stop()
    return dt


# ----- the hand-rolled peer --------------------------------------------------------------------
class HandRolled:
    """`towerlink sitl` as a child process on a free TCP port, with a connection retried until
    the socket exists and a wait for the estimator before arming."""

    def __init__(self, workdir: Path) -> None:
        self.port = free_port(socket.SOCK_STREAM)
        self.workdir = workdir

    def start(self):
        from pymavlink import mavutil
        self.t0 = time.perf_counter()
        self.proc = subprocess.Popen([sys.executable, "-m", "tools.cli", "sitl", "--drones", "1", "--rovers", "0",
                                      "--speedup", "max", "--no-save", "--endpoint",
                                      f"0=tcpin:127.0.0.1:{self.port}"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        end = time.monotonic() + 60
        while True:
            try:
                self.m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{self.port}", source_system=255, retries=0)
                break
            except OSError:
                if time.monotonic() > end or self.proc.poll() is not None:
                    raise
                time.sleep(0.1)  # poll: the child is still starting
        assert self.m.wait_heartbeat(timeout=10) is not None
        self.first_heartbeat = time.perf_counter() - self.t0
        prearm = mavutil.mavlink.MAV_SYS_STATUS_PREARM_CHECK
        self.wait("SYS_STATUS", lambda s: s.onboard_control_sensors_health & prearm, 30)
        self.m.close()
        return self

    def wait(self, kind: str, cond, timeout: float):
        m = self.m
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            msg = m.recv_match(type=kind, blocking=True, timeout=0.5)
            if msg is not None and cond(msg):
                return msg
        raise AssertionError(f"timed out waiting for {kind}")

    def stop(self) -> None:
        stop_process(self.proc)


def peer_test(ex, workdir: Path) -> tuple[float, float]:
    """(wall s of the example script on the hand-rolled fixture, its first heartbeat s)."""
    from pymavlink import mavutil
    armed = mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    t0 = time.perf_counter()
    w = HandRolled(workdir).start()
    try:
        w.m = ex.takeoff_fly_land(f"tcp:127.0.0.1:{w.port}", north=50.0, alt=10.0)
        w.wait("GLOBAL_POSITION_INT", lambda g: g.relative_alt > 9500, 60)
        ex.goto(w.m, 50.0, 0.0, -10.0)
        w.wait("LOCAL_POSITION_NED", lambda p: ((p.x - 50) ** 2 + p.y ** 2 + (p.z + 10) ** 2) ** 0.5 < 1.0, 60)
        w.m.set_mode("LAND")
        w.wait("HEARTBEAT", lambda h: h.type != 6 and not h.base_mode & armed, 90)
        w.m.close()
    finally:
        w.stop()
    return time.perf_counter() - t0, w.first_heartbeat


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_pytest", description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each side (default 3); medians")
    a = ap.parse_args(argv)
    ex = example()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="bench_pytest") as tmp:
        d = Path(tmp)
        mine = [fixture_test(ex, d / f"f{k}") for k in range(a.repeat)]
        mine_hb = [fixture_heartbeat(d / f"h{k}") for k in range(a.repeat)]
        peer = [peer_test(ex, d / f"p{k}") for k in range(a.repeat)]
    load1 = os.getloadavg()[0]
    m, mh = statistics.median(mine), statistics.median(mine_hb)
    p, ph = statistics.median(x[0] for x in peer), statistics.median(x[1] for x in peer)
    print(machine())
    print(table(f"example flight test (arm, take off 10 m, fly 50 m north, land; speedup max), "
                f"median of {a.repeat}",
                ["", "towerlink_sitl (s)", "hand-rolled subprocess (s)", "peer / fixture"],
                [["whole test, wall", f"{m:.2f}", f"{p:.2f}", f"{p / m:.1f}x"],
                 ["first heartbeat after the world starts", f"{mh:.3f}", f"{ph:.3f}", f"{ph / mh:.1f}x"]]))
    print(f"runs: fixture {', '.join(f'{x:.2f}' for x in mine)} s; peer {', '.join(f'{x[0]:.2f}' for x in peer)} s; "
          f"load average {load0:.1f} before, {load1:.1f} after (on {os.cpu_count()} cores)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
