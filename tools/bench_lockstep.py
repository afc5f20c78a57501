"""Benchmark: the lab in whole-system lockstep at --speedup max, the TICK round trip, start-up.

Each figure is measured for this tree, pipelined (the world steps on after each TICK and waits
for its ACKs at the next: fly's default, sitl --lockstep-pipeline) and not (fly
--no-lockstep-pipeline), and, side by side, for a peer checkout (the previous release: --peer
DIR or $TOWERLINK_PEER_TREE, e.g. a worktree of the last release; its default), each in its own
processes, with the ratio of this tree's default to the peer's:

* the lab run: `towerlink fly --speedup max` (lockstep, seed 1), wall seconds from the command's
  start to its summary (plots and run.mcap written), the speedup the flight achieved, the wait
  per TICK (the world's, for the bridge, the tower and fly's monitor), and the same run pinned
  to one core (taskset), whence runs a minute on one core and a 100-run sweep on this machine
  (extrapolated: its cores each flying runs one after another, as tools/sweep does); and the CPU
  seconds the pinned run took in all its processes (fly and every process it started, all
  reaped), which a loaded machine inflates far less than the wall: runs a minute and the sweep
  again, from that;
* the TICK round trip: `towerlink sitl --lockstep 1` (one drone) and a bare participant that
  ACKs each TICK at once; the world's wait per TICK, from the TICK's send to the ACK handled
  (its own stats line; pipelined, the wait left after stepping the next frame);
* start-up: wall seconds from starting `towerlink sitl` to its first HEARTBEAT (least of 3).

The machine is shared: the load average is printed with the figures.

  python -m tools.bench_lockstep [--peer DIR] [--runs N]
"""
from __future__ import annotations

import argparse
import json
import os
import resource
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
TICKS = re.compile(r"; (\d+) TICKs")
#: a lab run's and a world's flags per variant (None: the tree's default, e.g. a peer's)
FLY_FLAGS = {None: [], True: ["--lockstep-pipeline"], False: ["--no-lockstep-pipeline"]}
SITL_FLAGS = {None: [], True: ["--lockstep-pipeline"], False: []}


def _env(tree: Path) -> dict:
    return dict(os.environ, PYTHONPATH=str(tree), PYTHONWARNINGS="ignore")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "tools.cli", *args]


def _wait_per_tick(log: str) -> float | None:
    """The world's wall s waiting per TICK from its stats line (per wait where it does not count TICKs)."""
    m = WAITS.search(log)
    if not m:
        return None
    n = TICKS.search(log[m.end():m.end() + 200])
    count = int(n.group(1)) if n else int(m.group(1))
    return float(m.group(2)) / count if count else None


def lab_run(tree: Path, out: Path, one_core: bool = False, pipelined: bool | None = None) -> dict:
    """One `towerlink fly --speedup max` of the lab in `tree`: wall s, achieved speedup, wait per TICK."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = _cli("fly", "--speedup", "max", "--seed", "1", "-q", "--out", str(out), *FLY_FLAGS[pipelined])
    if one_core:
        cmd = ["taskset", "-c", "0", *cmd]
    cpu0 = _children_cpu()
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=tree, env=_env(tree), capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t0
    cpu = _children_cpu() - cpu0
    s = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    log = (out / "sitl.log").read_text() if (out / "sitl.log").exists() else ""
    return {"wall": wall, "cpu": cpu, "ok": r.returncode == 0 and bool(s.get("ok")),
            "speedup": s.get("achieved_speedup"), "tick_wait": _wait_per_tick(log)}


def _children_cpu() -> float:
    """CPU s (user + system) of this process's reaped children and all they reaped."""
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def tick_round_trip(tree: Path, ticks: int = 1500, pipelined: bool | None = None) -> float | None:
    """The world's wait per TICK (s) with one bare participant ACKing each TICK at once."""
    from common.mavlink import lockstep as wire
    port = _free_port()
    proc = subprocess.Popen(_cli("sitl", "--no-save", "--tcp-base", "0", "--udp-base", "0", "--drones", "1",
                                 "--rovers", "0", "--speedup", "max", "--lockstep", "1", "--lockstep-period", "0.02",
                                 "--endpoint", f"0=udpin:127.0.0.1:{port}", *SITL_FLAGS[pipelined]),
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
    return _wait_per_tick(out)


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


def measure(tree: Path, runs: int = 1, pipelined: bool | None = None, heartbeat: bool = True) -> dict:
    """The figures of `tree`, pipelined or not (None: its default)."""
    work = Path(tempfile.mkdtemp(prefix="bench_lockstep_"))
    try:
        labs = [lab_run(tree, work / f"lab{i}", pipelined=pipelined) for i in range(runs)]
        one = lab_run(tree, work / "one", one_core=True, pipelined=pipelined)
        return {"lab": min(labs, key=lambda r: r["wall"]), "one_core": one,
                "rtt": tick_round_trip(tree, pipelined=pipelined),
                "heartbeat": first_heartbeat(tree) if heartbeat else None}
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _f(v, spec: str) -> str:
    return "-" if v is None else format(v, spec)


def _ratio(new, old, lower_is_better: bool = True) -> str:
    if new is None or old is None or not new or not old:
        return "-"
    return f"{(old / new if lower_is_better else new / old):.2f}x"


def report(this: dict, peer: dict | None, peer_note: str, serial: dict | None = None) -> str:
    """The table: this tree (pipelined), this tree not pipelined (`serial`), the peer, the ratio."""
    empty = {"lab": {}, "one_core": {}, "rtt": None, "heartbeat": None}
    p, q = peer or empty, serial or empty
    cores = os.cpu_count() or 1

    def sweep_min(r, key="wall"):       # 100 runs, each core flying one after another
        return None if not r.get(key) else 100 * r[key] / cores / 60

    def per_min(r, key="wall"):
        return None if not r.get(key) else 60 / r[key]
    figures = [   # label, the figure of one measure(), format, lower is better, target
        ("lab run, start to summary (wall s)", lambda m: m["lab"].get("wall"), ".2f", True, "<= 5"),
        ("lab flight, achieved speedup (x)", lambda m: m["lab"].get("speedup"), ".1f", False, ">= 40"),
        ("lab wait per TICK: bridge, tower, monitor (ms)", lambda m: _ms(m["lab"].get("tick_wait")), ".3f",
         True, ""),
        ("lab run on one core (wall s)", lambda m: m["one_core"].get("wall"), ".2f", True, ""),
        ("runs a minute on one core", lambda m: per_min(m["one_core"]), ".1f", False, ">= 12"),
        (f"100-run sweep, {cores} cores (min, extrapolated)", lambda m: sweep_min(m["one_core"]), ".1f", True,
         "<= 5"),
        ("lab run on one core: CPU, all processes (s)", lambda m: m["one_core"].get("cpu"), ".2f", True, "<= 5"),
        ("runs a minute on one core, by CPU", lambda m: per_min(m["one_core"], "cpu"), ".1f", False, ">= 12"),
        (f"100-run sweep, {cores} cores, by CPU (min)", lambda m: sweep_min(m["one_core"], "cpu"), ".1f", True,
         "<= 5"),
        ("TICK round trip, bare participant: wait (ms)", lambda m: _ms(m["rtt"]), ".3f", True, "<= 0.3"),
        ("sitl start to first HEARTBEAT (s)", lambda m: m["heartbeat"], ".2f", True, "<= 0.5"),
    ]
    rows = [[label, _f(get(this), fmt), _f(get(q), fmt), _f(get(p), fmt), _ratio(get(this), get(p), lower), target]
            for label, get, fmt, lower, target in figures]
    ok = "" if this["lab"]["ok"] else "  (the lab run did not reach every goal)"
    return table(f"lockstep at --speedup max, start-up (peer: {peer_note}; load average "
                 f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}, a shared machine){ok}",
                 ["figure", "pipelined", "not pipelined", "peer", "pipelined/peer", "target"], rows)


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
    this = measure(tree, args.runs, pipelined=True)
    serial = measure(tree, args.runs, pipelined=False, heartbeat=False)
    peer, note = None, "none (--peer DIR or TOWERLINK_PEER_TREE)"
    if args.peer and (Path(args.peer) / "vehicle").is_dir():
        rev = subprocess.run(["git", "-C", args.peer, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        note = f"{args.peer} at {rev.stdout.strip() or '?'}"
        peer = measure(Path(args.peer), args.runs)
    print(report(this, peer, note, serial), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
