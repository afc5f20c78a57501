"""What the bridge benchmarks share: a pinned child process, loopback sockets, the goal latency
probe, packet counting and MAVProxy as the peer router.

tools.bench_bridge (latency and forwarding rate) and tools.bench_bridge_fleet (latency with
1,000 vehicles' telemetry flowing) measure with these. Times are seconds (time.perf_counter);
CPU figures are seconds of a process's user + system time (/proc).
"""
from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager

from common.mavlink.dialect import towerlink as tl
from common.mavlink.ids import TOWER_SYSID
from tools.benchtable import stop_process

ADDED_P99_TARGET_MS = 1.0
BRIDGE_SYSID = 250          # the bridge's own messages (not counted as forwarded)
TOWER_COMPONENT = 190       # the probe's component on the tower link
WARM_UP = 200               # latency samples of each link left out at the start


def cpu_seconds(pid: int) -> float:
    """CPU seconds (user + system) process `pid` has used so far (/proc/PID/stat)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def runqueue_wait(pid: int) -> float:
    """Seconds process `pid` has spent runnable but waiting for a CPU (/proc/PID/schedstat)."""
    try:
        with open(f"/proc/{pid}/schedstat") as f:
            return int(f.read().split()[1]) / 1e9
    except (OSError, IndexError, ValueError):
        return float("nan")


def split_cpus() -> tuple[int, set[int]]:
    """(the CPU for the process under test, the CPUs left for this process)."""
    cpus = sorted(os.sched_getaffinity(0))
    return cpus[-1], (set(cpus[:-1]) or set(cpus))


def udp_socket(port: int = 0, rcvbuf: int = 8 << 20) -> socket.socket:
    """A UDP socket bound on loopback (port 0: any free one) with a large receive buffer."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    s.bind(("127.0.0.1", port))
    return s


@contextmanager
def pinned_process(args: list[str], cpu: int, cwd: str | None = None):
    """A child process pinned to `cpu` (os.sched_setaffinity before exec); always stopped.

    Its stderr goes to a temporary file (a pipe nobody reads could fill and stall it);
    `proc.stderr_tail()` returns the end of it, for error messages."""
    err = tempfile.TemporaryFile()
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=err, stdin=subprocess.DEVNULL,
                            cwd=cwd, start_new_session=True, preexec_fn=lambda: os.sched_setaffinity(0, {cpu}))

    def stderr_tail(n: int = 2000) -> str:
        err.seek(0)
        return err.read().decode(errors="replace")[-n:]
    proc.stderr_tail = stderr_tail
    try:
        yield proc
    finally:
        stop_process(proc)
        err.close()


def bridge_args(tower_port: int, *links: str) -> list[str]:
    """`towerlink bridge` with its tower link on `tower_port`, the given vehicle-link flags,
    no follow and no telemetry of its own: only what it routes."""
    return [sys.executable, "-m", "tools.cli", "bridge", "--tower", f"udpin:127.0.0.1:{tower_port}",
            *links, "--no-follow", "--telemetry-rate", "0", "-q"]


def first_heartbeat_from(sock: socket.socket, proc, timeout: float = 15.0) -> tuple:
    """The address the bridge's link sends from, once its first heartbeat reaches `sock`."""
    sock.settimeout(timeout)
    try:
        _data, addr = sock.recvfrom(65535)
    except socket.timeout:
        raise RuntimeError(f"`towerlink bridge` sent nothing in {timeout:g} s:\n{proc.stderr_tail()}") from None
    return addr


def place_drone(drone: socket.socket, link_addr: tuple) -> None:
    """Send the drone's GPS_GLOBAL_ORIGIN, as a vehicle does once its EKF origin is set: the
    bridge places the drone's frame (drone_origin) in world with it, so tower goals have
    somewhere to go."""
    drone.sendto(bytes(tl.MAVLink_gps_global_origin_message(-353632610, 1491652300, 584000, 0)
                       .pack(tl.MAVLink(None, 1, 1))), link_addr)


def hello_tower(tower: socket.socket, addr: tuple, proc, timeout: float = 15.0) -> None:
    """Heartbeat as the tower until the bridge answers on its tower link."""
    hb = bytes(tl.MAVLink_heartbeat_message(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
               .pack(tl.MAVLink(None, TOWER_SYSID, TOWER_COMPONENT)))
    tower.settimeout(0.2)
    deadline = time.monotonic() + timeout
    while True:
        tower.sendto(hb, addr)
        try:
            tower.recv(65535)
            return
        except socket.timeout:
            if time.monotonic() > deadline or proc.poll() is not None:
                raise RuntimeError(f"the bridge did not answer the tower:\n{proc.stderr_tail()}") from None


# ----------------------------------------------------------------------------- latency

def _goal(mav, k: int) -> bytes:
    """A tower goal whose time_boot_ms carries the sample number k."""
    return bytes(tl.MAVLink_set_position_target_local_ned_message(
        k, 1, 1, tl.MAV_FRAME_LOCAL_NED, 0b0000_1101_1111_1000, -131.0, 73.5, -9.0,
        0, 0, 0, 0, 0, 0, 0, 0).pack(mav))


def _is_goal(data: bytes, k: int) -> bool:
    if len(data) < 14 or data[0] != 0xFD or data[7:10] != b"\x54\x00\x00":   # msgid 84
        return False
    return int.from_bytes(data[10:14].ljust(4, b"\0"), "little") == k


def latency(bridge: tuple, samples: int) -> dict[str, list[float]]:
    """One-way times (s) of tower goals through the bridge and over a direct link.

    `bridge` is (proc, tower socket, drone socket, -, the bridge's tower link address). Returns
    {"bridge": [s], "direct": [s], "lost": [through the bridge, direct], "wait": [runqueue s]}."""
    mav = tl.MAVLink(None, TOWER_SYSID, TOWER_COMPONENT)
    out: dict[str, list[float]] = {"bridge": [], "direct": [], "lost": [0, 0], "wait": [0.0]}
    proc, tower, drone, _link, tower_link = bridge
    drone.settimeout(1.0)
    direct = drone.getsockname()
    clock = time.perf_counter
    for i in range(samples + WARM_UP):
        if i == WARM_UP:
            out["wait"][0] = -runqueue_wait(proc.pid)
        for j, (name, dest) in enumerate((("bridge", tower_link), ("direct", direct))):
            k = 2 * i + j + 1
            frame = _goal(mav, k)
            t0 = clock()
            tower.sendto(frame, dest)
            while True:
                try:
                    data = drone.recv(65535)
                except socket.timeout:
                    out["lost"][j] += 1
                    break
                if _is_goal(data, k):
                    if i >= WARM_UP:
                        out[name].append(clock() - t0)
                    break
    out["wait"][0] += runqueue_wait(proc.pid)
    return out


def percentile(xs: list[float], q: float) -> float:
    """The q-th percentile (0..100) of xs, nearest rank."""
    s = sorted(xs)
    return s[min(len(s) - 1, int(round(q / 100.0 * (len(s) - 1))))]


# ----------------------------------------------------------------------------- counting

def messages_in(data: bytes, skip_sysid: int = BRIDGE_SYSID) -> int:
    """How many MAVLink packets a datagram holds (the bridge coalesces forwarded telemetry),
    not counting those from `skip_sysid` (the bridge's own)."""
    n, i = 0, 0
    while i + 6 <= len(data):
        if data[i] == 0xFD:
            size = 12 + data[i + 1] + (13 if data[i + 2] & 1 else 0)
            sysid = data[i + 5]
        elif data[i] == 0xFE:
            size, sysid = 8 + data[i + 1], data[i + 3]
        else:
            break
        if sysid != skip_sysid:
            n += 1
        i += size
    return n


# ----------------------------------------------------------------------------- the peer

def mavproxy_exe() -> str | None:
    """MAVProxy's script beside this Python (or on PATH); None when it is not installed."""
    exe = shutil.which("mavproxy.py") or os.path.join(os.path.dirname(sys.executable), "mavproxy.py")
    return exe if os.path.exists(exe) else None


def mavproxy_router_args(master_port: int, out_port: int, state_dir: str) -> list[str]:
    """MAVProxy as a plain router, the peer of the bridge: udpin master on loopback, one udpout."""
    return [sys.executable, mavproxy_exe() or "mavproxy.py", f"--master=udpin:127.0.0.1:{master_port}",
            f"--out=udpout:127.0.0.1:{out_port}", "--daemon", "--non-interactive",
            "--state-basedir", state_dir, "--no-state"]
