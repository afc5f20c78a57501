"""Benchmark: the lab in whole-system lockstep at --speedup max, the TICK round trip, start-up.

Each figure is measured for this tree and, side by side, for a peer checkout (the previous
release: --peer DIR or $TOWERLINK_PEER_TREE, e.g. a worktree of the last release), each in its
own processes, with the ratio:

* the lab run: `towerlink fly --speedup max` (lockstep, seed 1), wall seconds from the command's
  start to its summary (plots and run.mcap written), the speedup the flight achieved, the wait
  per TICK (the world's, for the bridge, the tower and fly's monitor), and the same run pinned
  to one core (taskset), whence runs a minute on one core and a 100-run sweep on this machine
  (extrapolated: its cores each flying runs one after another, as tools/sweep does);
* the TICK round trip: `towerlink sitl --lockstep 1` (one drone) and a bare participant that
  ACKs each TICK at once; the world's wait per TICK, from the TICK's send to the ACK handled
  (its own stats line);
* start-up: wall seconds from starting `towerlink sitl` to its first HEARTBEAT (least of 3).

The machine is shared: the load average is printed with the figures.

  python -m tools.bench_lockstep [--peer DIR] [--runs N]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tools.benchtable import machine, table

WAITS = re.compile(r"lockstep: (\d+) waits for ACKs, ([\d.]+) s wall waiting")


def _env(tree: Path) -> dict:
    return dict(os.environ, PYTHONPATH=str(tree), PYTHONWARNINGS="ignore")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "tools.cli", *args]


def lab_run(tree: Path, out: Path, one_core: bool = False) -> dict:
    """One `towerlink fly --speedup max` of the lab in `tree`: wall s, achieved speedup, wait per TICK."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = _cli("fly", "--speedup", "max", "--seed", "1", "-q", "--out", str(out))
    if one_core:
        cmd = ["taskset", "-c", "0", *cmd]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=tree, env=_env(tree), capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    s = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    m = WAITS.search((out / "sitl.log").read_text()) if (out / "sitl.log").exists() else None
    return {"wall": wall, "ok": r.returncode == 0 and bool(s.get("ok")),
            "speedup": s.get("achieved_speedup"),
            "tick_wait": float(m.group(2)) / int(m.group(1)) if m and int(m.group(1)) else None}


def tick_round_trip(tree: Path, ticks: int = 1500) -> float | None:
    """The world's wait per TICK (s) with one bare participant ACKing each TICK at once."""
    from common.mavlink import lockstep as wire
    port = _free_port()
    proc = subprocess.Popen(_cli("sitl", "--no-save", "--tcp-base", "0", "--udp-base", "0", "--drones", "1",
                                 "--rovers", "0", "--speedup", "max", "--lockstep", "1", "--lockstep-period", "0.02",
                                 "--endpoint", f"0=udpin:127.0.0.1:{port}"),
                            cwd=tree, env=_env(tree), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    addr = ("127.0.0.1", port)
    ids = {"participant": wire.OTHER, "sysid": 254, "compid": 7}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        s.settimeout(0.2)
        seen, deadline = 0, time.monotonic() + 120
        while seen < ticks and time.monotonic() < deadline:
            if seen == 0:
                s.sendto(wire.pack(wire.JOIN, 0, **ids), addr)
            try:
                m, _ = wire.unpack(s.recv(65535))
            except socket.timeout:
                continue
            if m is not None and m.kind == wire.TICK:
                seen += 1
                s.sendto(wire.pack(wire.ACK, m.time_usec, **ids), addr)
        s.sendto(wire.pack(wire.LEAVE, 0, **ids), addr)
    proc.send_signal(signal.SIGTERM)
    try:
        out = proc.communicate(timeout=30)[0]
    except subprocess.TimeoutExpired:
        proc.kill()
        out = proc.communicate()[0]
    m = WAITS.search(out)
    return float(m.group(2)) / int(m.group(1)) if m and int(m.group(1)) else None


def first_heartbeat(tree: Path, repeat: int = 3) -> float | None:
    """Least wall s from starting `towerlink sitl` to its first HEARTBEAT (on a udpout push)."""
    best = None
    for _ in range(repeat):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.bind(("127.0.0.1", 0))
            s.settimeout(30)
            t0 = time.perf_counter()
            proc = subprocess.Popen(_cli("sitl", "--no-save", "--tcp-base", "0", "--udp-base", "0",
                                         "--out", f"udpout:127.0.0.1:{s.getsockname()[1]}"),
                                    cwd=tree, env=_env(tree), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                while not _has_heartbeat(s.recv(65535)):
                    pass
                took = time.perf_counter() - t0
            except socket.timeout:
                took = None
            finally:
                proc.terminate()
                proc.wait(10)
        if took is not None and (best is None or took < best):
            best = took
    return best


def _has_heartbeat(data: bytes) -> bool:
    i = 0
    while i + 10 <= len(data) and data[i] == 0xFD:
        if data[i + 7:i + 10] == b"\0\0\0":
            return True
        i += 12 + data[i + 1] + (13 if data[i + 2] & 1 else 0)
    return False


def measure(tree: Path, runs: int = 1) -> dict:
    work = Path(tempfile.mkdtemp(prefix="bench_lockstep_"))
    try:
        labs = [lab_run(tree, work / f"lab{i}") for i in range(runs)]
        one = lab_run(tree, work / "one", one_core=True)
        return {"lab": min(labs, key=lambda r: r["wall"]), "one_core": one,
                "rtt": tick_round_trip(tree), "heartbeat": first_heartbeat(tree)}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _f(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _ratio(new, old, lower_is_better: bool = True) -> str:
    if new is None or old is None or not new or not old:
        return "-"
    return f"{(old / new if lower_is_better else new / old):.2f}x"


def report(this: dict, peer: dict | None, peer_note: str) -> str:
    p = peer or {"lab": {}, "one_core": {}, "rtt": None, "heartbeat": None}
    cores = os.cpu_count() or 1

    def sweep_min(r):       # 100 runs, each core flying one after another
        return None if not r.get("wall") else 100 * r["wall"] / cores / 60

    def per_min(r):
        return None if not r.get("wall") else 60 / r["wall"]
    rows = [
        ["lab run, start to summary (wall s)", _f(this["lab"]["wall"], ".2f"), _f(p["lab"].get("wall"), ".2f"),
         _ratio(this["lab"]["wall"], p["lab"].get("wall")), "<= 5"],
        ["lab flight, achieved speedup (x)", _f(this["lab"]["speedup"], ".1f"), _f(p["lab"].get("speedup"), ".1f"),
         _ratio(this["lab"]["speedup"], p["lab"].get("speedup"), False), ">= 40"],
        ["lab wait per TICK: bridge, tower, monitor (ms)", _f(_ms(this["lab"]["tick_wait"]), ".3f"),
         _f(_ms(p["lab"].get("tick_wait")), ".3f"), _ratio(this["lab"]["tick_wait"], p["lab"].get("tick_wait")), ""],
        ["lab run on one core (wall s)", _f(this["one_core"]["wall"], ".2f"), _f(p["one_core"].get("wall"), ".2f"),
         _ratio(this["one_core"]["wall"], p["one_core"].get("wall")), ""],
        ["runs a minute on one core", _f(per_min(this["one_core"]), ".1f"), _f(per_min(p["one_core"]), ".1f"),
         _ratio(per_min(this["one_core"]), per_min(p["one_core"]), False), ">= 12"],
        [f"100-run sweep, {cores} cores (min, extrapolated)", _f(sweep_min(this["one_core"]), ".1f"),
         _f(sweep_min(p["one_core"]), ".1f"), _ratio(sweep_min(this["one_core"]), sweep_min(p["one_core"])), "<= 5"],
        ["TICK round trip, bare participant (ms)", _f(_ms(this["rtt"]), ".3f"), _f(_ms(p["rtt"]), ".3f"),
         _ratio(this["rtt"], p["rtt"]), "<= 0.3"],
        ["sitl start to first HEARTBEAT (s)", _f(this["heartbeat"], ".2f"), _f(p["heartbeat"], ".2f"),
         _ratio(this["heartbeat"], p["heartbeat"]), "<= 0.5"],
    ]
    ok = "" if this["lab"]["ok"] else "  (the lab run did not reach every goal)"
    return table(f"lockstep at --speedup max, start-up (peer: {peer_note}; load average "
                 f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, a shared machine){ok}",
                 ["figure", "this tree", "peer", "this/peer", "target"], rows)


def _ms(v):
    return None if v is None else v * 1e3


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--peer", default=os.environ.get("TOWERLINK_PEER_TREE"),
                    help="a checkout of the previous release to measure side by side")
    ap.add_argument("--runs", type=int, default=1, help="lab runs on all cores; the fastest counts")
    args = ap.parse_args(argv)
    tree = Path(__file__).resolve().parent.parent
    print(machine(), flush=True)
    this = measure(tree, args.runs)
    peer, note = None, "none (--peer DIR or TOWERLINK_PEER_TREE)"
    if args.peer and (Path(args.peer) / "vehicle").is_dir():
        rev = subprocess.run(["git", "-C", args.peer, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        note = f"{args.peer} at {rev.stdout.strip() or '?'}"
        peer = measure(Path(args.peer), args.runs)
    print(report(this, peer, note), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
