"""Benchmark helpers: the machine line, side-by-side tables with ratios, stopping a child.

Every benchmark prints through here so `make bench` reads as one report.
"""
from __future__ import annotations

import os
import platform
import statistics
import subprocess
import time
from collections.abc import Callable, Sequence


def machine() -> str:
    """One line naming the machine the figures were measured on."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return (f"{platform.node()} | {cpu} | {os.cpu_count()} cores | "
            f"Python {platform.python_version()} | {platform.system()} {platform.release()}")


def load_line() -> str:
    """The load average now (1, 5, 15 min): how shared the machine was while measuring."""
    try:
        one, five, fifteen = os.getloadavg()
    except OSError:
        return "load average: unknown"
    return f"load average: {one:.2f}, {five:.2f}, {fifteen:.2f} ({os.cpu_count()} cores)"


def median_time(fn: Callable[[], object], repeat: int, inner: int = 1) -> float:
    """Median wall seconds of one call of `fn`, over `repeat` samples of `inner` calls."""
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        samples.append((time.perf_counter() - t0) / inner)
    return statistics.median(samples)


def table(title: str, header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A plain-text table; numbers are formatted by the caller."""
    cells = [list(map(str, header))] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    line = "  ".join("-" * w for w in widths)
    out = [title, line]
    for k, r in enumerate(cells):
        out.append("  ".join(c.ljust(w) if i == 0 or k == 0 else c.rjust(w)
                             for i, (c, w) in enumerate(zip(r, widths))))
        if k == 0:
            out.append(line)
    return "\n".join(out)


def stop_process(proc: subprocess.Popen, timeout: float = 10.0) -> None:
    """Terminate a benchmark's child (a sitl or bridge), killing it if it will not stop."""
    proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
