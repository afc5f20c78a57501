"""Benchmark: a 100-item mission uploaded to and downloaded from a SITL drone over loopback UDP,
by pymavlink (the request/answer loop a script writes) and by MAVSDK's mission_raw plugin,
side by side; the ratio column is MAVSDK / pymavlink.

The SITL runs as `towerlink sitl` in a child process at speedup 1; the MAVSDK client in
another (native library). Times are wall seconds per whole transfer, median of --repeat.
Usage: python -m tools.bench_mission_transfer [--items 100] [--repeat 5]   (towerlink bench mission-transfer)
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

from common.ports import free_port
from tools.benchtable import machine, table, stop_process

HOME = (-35.363261, 149.165230, 584.0)
REL = 6   # MAV_FRAME_GLOBAL_RELATIVE_ALT_INT



def _items(n: int) -> list[tuple]:
    """(seq, frame, command, p1..p4, x, y, z): home, then n-1 waypoints on a line north."""
    lat, lon, alt = HOME
    out = [(0, 0, 16, 0.0, 0.0, 0.0, 0.0, int(lat * 1e7), int(lon * 1e7), alt)]
    out += [(i, REL, 16, 0.0, 0.0, 0.0, 0.0, int((lat + 1e-5 * i) * 1e7), int(lon * 1e7), 20.0) for i in range(1, n)]
    return out


# ----- pymavlink ----------------------------------------------------------------------------
def _pymavlink(port: int, n: int, repeat: int) -> tuple[list[float], list[float]]:
    os.environ.setdefault("MAVLINK20", "1")
    from pymavlink import mavutil
    mav = mavutil.mavlink
    m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    end = time.monotonic() + 20
    while not m.wait_heartbeat(timeout=0.5):
        m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        if time.monotonic() > end:
            raise SystemExit("pymavlink: no heartbeat")
    ts, tc = m.target_system, m.target_component
    msgs = [mav.MAVLink_mission_item_int_message(ts, tc, *it[:3], 0, 1, *it[3:], 0) for it in _items(n)]
    ups, downs = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        m.mav.mission_count_send(ts, tc, n, 0)
        while True:
            r = m.recv_match(type=["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], blocking=True, timeout=5)
            if r is None:
                raise SystemExit("pymavlink: upload stalled")
            if r.get_type() == "MISSION_ACK":
                if r.type != mav.MAV_MISSION_ACCEPTED:
                    raise SystemExit(f"pymavlink: upload refused {r.type}")
                break
            m.mav.send(msgs[r.seq])
        ups.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        m.mav.mission_request_list_send(ts, tc, 0)
        count = m.recv_match(type="MISSION_COUNT", blocking=True, timeout=5).count
        for seq in range(count):
            m.mav.mission_request_int_send(ts, tc, seq, 0)
            it = m.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=5)
            if it is None or it.seq != seq:
                raise SystemExit(f"pymavlink: download stalled at {seq}")
        m.mav.mission_ack_send(ts, tc, mav.MAV_MISSION_ACCEPTED, 0)
        downs.append(time.perf_counter() - t0)
    m.close()
    return ups, downs


# ----- MAVSDK (runs in its own process: python -m tools.bench_mission_transfer --mavsdk-client PORT N R) ----
def _mavsdk_client(port: int, n: int, repeat: int) -> int:
    from mavsdk import ComponentType, Configuration, Mavsdk
    from mavsdk.plugins.mission_raw import MissionItem, MissionRaw
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = sdk.first_autopilot(20.0)
    if system is None:
        raise SystemExit("MAVSDK: no autopilot")
    raw = MissionRaw(system)
    # MAVSDK wants exactly one item marked current: home
    items = [MissionItem(it[0], it[1], it[2], int(it[0] == 0), 1, *it[3:], 0) for it in _items(n)]
    ups, downs = [], []
    for _ in range(repeat):
        t0 = time.perf_counter()
        raw.upload_mission(items)
        ups.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        got = raw.download_mission()
        downs.append(time.perf_counter() - t0)
        if len(got) != n:
            raise SystemExit(f"MAVSDK: downloaded {len(got)} items")
    print("RESULT " + json.dumps({"up": ups, "down": downs}), flush=True)
    return 0


def _mavsdk(port: int, n: int, repeat: int) -> tuple[list[float], list[float]]:
    r = subprocess.run([sys.executable, "-m", "tools.bench_mission_transfer", "--mavsdk-client", str(port), str(n), str(repeat)],
                       capture_output=True, text=True, timeout=300)
    for line in r.stdout.splitlines():
        if line.startswith("RESULT "):
            d = json.loads(line[7:])
            return d["up"], d["down"]
    raise SystemExit("MAVSDK client failed:\n" + r.stdout[-2000:] + r.stderr[-600:])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench_mission_transfer", description=__doc__.split("\n\n")[0])
    ap.add_argument("--items", type=int, default=100, help="items per mission, home included (default 100)")
    ap.add_argument("--repeat", type=int, default=5, help="transfers per client (default 5; median shown)")
    ap.add_argument("--mavsdk-client", nargs=3, type=int, metavar=("PORT", "N", "REPEAT"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.mavsdk_client:
        return _mavsdk_client(*a.mavsdk_client)
    udp, out = free_port(), free_port()
    cmd = [sys.executable, "-m", "tools.cli", "sitl", "--drones", "1", "--rovers", "0", "--speedup", "1",
           "--no-save", "--tcp-base", "0", "--udp-base", "0", "--endpoint", f"0=udpin:127.0.0.1:{udp}",
           "--out", f"udpout:127.0.0.1:{out}"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        pu, pd = _pymavlink(udp, a.items, a.repeat)
        mu, md = _mavsdk(out, a.items, a.repeat)
    finally:
        stop_process(proc)
    med = statistics.median
    print(machine())
    rows = [[f"upload {a.items} items", f"{med(pu) * 1e3:.1f}", f"{med(mu) * 1e3:.1f}", f"{med(mu) / med(pu):.2f}"],
            [f"download {a.items} items", f"{med(pd) * 1e3:.1f}", f"{med(md) * 1e3:.1f}", f"{med(md) / med(pd):.2f}"]]
    print(table(f"Mission transfer over loopback UDP, towerlink sitl (speedup 1), median of {a.repeat}",
                ["transfer", "pymavlink (ms)", "MAVSDK (ms)", "MAVSDK / pymavlink"], rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
