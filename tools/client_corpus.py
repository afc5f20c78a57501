"""Run the client corpus (examples/clients/corpus.toml) against `towerlink sitl` and count the
programs that behave as they would against ArduPilot SITL.

For each program: a fresh world (one drone, nothing saved) on free ports, a watcher on its UDP
endpoint (tools.client_corpus_watch), the program with a wall-clock timeout, then the checks of
its manifest entry (tools.client_corpus_checks). Everything started is stopped, whatever
happens. Ends with a table and "N of M behave as against ArduPilot SITL".

    python -m tools.client_corpus                      # all of it (make clients)
    python -m tools.client_corpus --only mavproxy      # names matching a regex
    python -m tools.client_corpus --markdown docs/CLIENTS.md
"""
from __future__ import annotations

import argparse
import os
import platform
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from common.ports import free_ports
from tools.client_corpus_checks import failures
from tools.client_corpus_plan import Program, load
from tools.client_corpus_watch import Watcher
from tools.procs import die_with_parent

ROOT = Path(__file__).resolve().parent.parent
MANIFEST = ROOT / "examples" / "clients" / "corpus.toml"
BANNER_TIMEOUT = 30.0      # wall s for the world to print its vehicle line (a loaded machine)


@dataclass
class Outcome:
    program: Program
    behaves: bool
    reasons: list[str]
    seconds: float
    summary: str


def mavsdk3_python() -> str | None:
    """MAVSDK-Python 3.x's interpreter: MAVSDK3_PYTHON, else the Makefile's .venv/mavsdk3."""
    for cand in (os.environ.get("MAVSDK3_PYTHON"), ROOT / ".venv/mavsdk3/bin/python",
                 Path(sys.prefix) / "mavsdk3/bin/python"):
        if cand and Path(cand).exists():
            return str(cand)
    return None


def command_for(p: Program, ports: dict[str, int]) -> list[str]:
    args = p.argv(ports)
    if p.kind == "mavproxy":
        return [sys.executable, "-m", "tools.client_corpus_mavproxy", *args]
    if p.kind == "mavsdk3":
        py = mavsdk3_python()
        if py is None:
            raise RuntimeError("no MAVSDK 3.x interpreter (make mavsdk3, or set MAVSDK3_PYTHON)")
        return [py, str(p.path), *args]
    return [sys.executable, str(p.path), *args]


class Child:
    """A process in a session of its own, its output collected on a thread."""

    def __init__(self, argv: list[str], cwd: Path) -> None:
        self.lines: list[str] = []
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                     stdin=subprocess.DEVNULL, cwd=str(cwd), start_new_session=True,
                                     preexec_fn=die_with_parent(), errors="replace")
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)

    def output(self) -> str:
        return "".join(self.lines)

    def wait(self, timeout: float) -> bool:
        """True when it ended within timeout wall s."""
        try:
            self.proc.wait(timeout)
            self._reader.join(2.0)
            return True
        except subprocess.TimeoutExpired:
            return False

    def stop(self) -> None:
        """SIGINT, SIGTERM, then SIGKILL to its session, each after a grace; then whatever is left in it."""
        if self.proc.poll() is None:
            for sig, grace in ((signal.SIGINT, 3.0), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
                try:
                    os.killpg(self.proc.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    self.proc.wait(grace)
                    break
                except subprocess.TimeoutExpired:
                    continue
        try:        # what it left behind in its session (MAVSDK 3.x's mavsdk_server)
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self._reader.join(2.0)


def towerlink_exe() -> str:
    exe = Path(sys.executable).with_name("towerlink")
    return str(exe) if exe.exists() else "towerlink"


def start_world(p: Program, ports: dict[str, int], workdir: Path) -> Child:
    argv = [towerlink_exe(), "sitl", "--drones", "1", "--rovers", "0", "--no-save",
            "--speedup", f"{p.speedup:g}",
            "--endpoint", f"0=udpin:127.0.0.1:{ports['udp']}", "--endpoint", f"0=tcpin:127.0.0.1:{ports['tcp']}",
            "--out", f"udpout:127.0.0.1:{ports['out']}", *p.sitl]
    world = Child(argv, workdir)
    end = time.monotonic() + BANNER_TIMEOUT
    while time.monotonic() < end and world.proc.poll() is None:
        if any("vehicle 0:" in line for line in world.lines):
            return world
        time.sleep(0.05)  # poll the banner the reader thread collects
    world.stop()
    raise RuntimeError("the world did not start:\n" + world.output()[-2000:])


def run_one(p: Program, workdir: Path) -> Outcome:
    """One program against a fresh world; always stops what it started."""
    t0 = time.monotonic()
    udp, out = free_ports(2)
    tcp, grpc = free_ports(2, kind=socket.SOCK_STREAM)
    ports = {"udp": udp, "tcp": tcp, "out": out, "grpc": grpc}
    workdir.mkdir(parents=True, exist_ok=True)
    world = watcher = child = None
    try:
        world = start_world(p, ports, workdir)
        watcher = Watcher(udp)
        watcher.start()
        child = Child(command_for(p, ports), workdir)
        ended = child.wait(p.timeout)
        if not ended:
            child.stop()
        if "disarmed" in p.checks:
            watcher.wait_disarmed(p.settle)
        else:
            time.sleep(0.5)   # the last telemetry of the run reaches the watcher
        output = child.output()
        reasons = failures(list(p.checks), watcher.record, output, child.proc.returncode, p.exit, not ended)
        summary = watcher.record.summary()
    except Exception as exc:  # noqa: BLE001 - a broken run is a result, not a crash of the corpus
        output = child.output() if child else ""
        reasons, summary = [f"runner: {exc}"], ""
    finally:
        for c in (child, world):
            if c is not None:
                c.stop()
        if watcher is not None:
            watcher.stop()
    (workdir / "program.log").write_text(output)
    if watcher is not None:
        (workdir / "statustext.log").write_text("".join(t + "\n" for t in watcher.record.texts))
    if world is not None:
        (workdir / "sitl.log").write_text(world.output())
    return Outcome(p, not reasons, reasons, time.monotonic() - t0, summary)


def run_all(programs: list[Program], workdir: Path, jobs: int) -> list[Outcome]:
    """Every program, `jobs` at a time, each line of progress as one ends; in manifest order."""
    from concurrent.futures import ThreadPoolExecutor, as_completed
    done = 0
    with ThreadPoolExecutor(max(1, jobs)) as pool:
        futures = {pool.submit(run_one, p, workdir / p.name): p for p in programs}
        for fut in as_completed(futures):
            o = fut.result()
            done += 1
            verdict = "behaves" if o.behaves else "DIFFERS: " + "; ".join(o.reasons)
            print(f"[{done:2d}/{len(programs)}] {o.program.name} ({o.program.kind}, speedup {o.program.speedup:g}): "
                  f"{verdict} ({o.seconds:.0f} s)", flush=True)
            if not o.behaves:
                print(f"        the vehicle: {o.summary}", flush=True)
    order = {p.name: i for i, p in enumerate(programs)}
    return sorted((f.result() for f in futures), key=lambda o: order[o.program.name])


def by_kind(outcomes: list[Outcome]) -> str:
    """'mavsdk3 12/16, pymavlink 7/10, ...' in the manifest's order of kinds."""
    kinds: dict[str, list[bool]] = {}
    for o in outcomes:
        kinds.setdefault(o.program.kind, []).append(o.behaves)
    return ", ".join(f"{k} {sum(v)}/{len(v)}" for k, v in kinds.items())


def markdown(outcomes: list[Outcome], wall: float, jobs: int) -> str:
    """The result table with date, machine and load, for docs/CLIENTS.md."""
    behaves = sum(o.behaves for o in outcomes)
    load1, load5, _ = os.getloadavg()
    lines = [
        "# Client programs against `towerlink sitl`",
        "",
        ("Programs nobody here wrote, written the way their users write them (MAVSDK-Python's examples, "
         "pymavlink's examples, MAVProxy typed commands, checks after ArduPilot's autotest helpers), "
         "each run against a fresh `towerlink sitl` and checked against what it does against "
         "ArduPilot SITL. The programs and their expectations: `examples/clients/` and "
         "`examples/clients/corpus.toml`; the runner: `make clients` (`python -m tools.client_corpus`)."),
        "",
        f"**{behaves} of {len(outcomes)} behave as against ArduPilot SITL.** By kind: " + by_kind(outcomes) + ".",
        "",
        ("A program behaves when it does what it does against ArduPilot SITL, failures included: "
         "MAVSDK's own mission example fails its upload on ArduPilot, so it behaves when it fails "
         "the same way here. Each program's output, the world's log and the STATUSTEXT it sent are "
         "kept in `runs/clients/<program>/`."),
        "",
        (f"Run {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} on {platform.node()} "
         f"({os.cpu_count()} cores, Python {platform.python_version()}), load average {load1:.2f} / {load5:.2f} "
         f"(1 / 5 min) at the end, {wall / 60:.1f} min in all with {jobs} program(s) at once."),
        "",
        "| program | kind | written after | result | why it differs | what the vehicle did |",
        "|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        p = o.program
        lines.append(f"| {p.name} | {p.kind} | {p.source} | {'behaves' if o.behaves else '**differs**'} | "
                     f"{'; '.join(o.reasons).replace('|', '/')} | {o.summary} |")
    lines += ["", "What each program does against ArduPilot SITL (the expectation its checks encode):", ""]
    lines += [f"- **{o.program.name}**: {o.program.ardupilot}" for o in outcomes]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.client_corpus", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--manifest", type=Path, default=MANIFEST)
    ap.add_argument("--only", help="run the programs whose name matches this regex")
    ap.add_argument("--workdir", type=Path, default=ROOT / "runs" / "clients",
                    help="where each program's output and the world's log are kept")
    ap.add_argument("--markdown", type=Path, help="write the result table here (docs/CLIENTS.md)")
    ap.add_argument("--list", action="store_true", help="list the programs and exit")
    ap.add_argument("--jobs", type=int, default=2,
                    help="programs run at once, each with its own world (default 2)")
    ap.add_argument("--strict", action="store_true", help="exit 1 unless every program behaves")
    args = ap.parse_args(argv)
    programs = load(args.manifest).select(args.only)
    if args.list:
        for p in programs:
            print(f"{p.name:32s} {p.kind:9s} {p.source}")
        return 0
    t0 = time.monotonic()
    outcomes = run_all(programs, args.workdir, args.jobs)
    behaves = sum(o.behaves for o in outcomes)
    print()
    width = max((len(o.program.name) for o in outcomes), default=10)
    for o in outcomes:
        print(f"{o.program.name:{width}s}  {'behaves' if o.behaves else 'differs'}  {'; '.join(o.reasons)}")
    print(f"\n{behaves} of {len(outcomes)} behave as against ArduPilot SITL ({by_kind(outcomes)}; "
          f"{(time.monotonic() - t0) / 60:.1f} min)")
    if args.markdown:
        args.markdown.write_text(markdown(outcomes, time.monotonic() - t0, args.jobs))
        print(f"wrote {args.markdown}")
    return 1 if args.strict and behaves < len(outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
