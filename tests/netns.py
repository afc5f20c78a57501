"""Two test hosts as Linux network namespaces joined by a veth pair (issue 11, across machines).

`two_hosts()` makes them, yields them, and removes them (and anything still running in
them) whatever happens. Names carry this process's pid and a random part, and the pair gets
its own /30, so parallel runs never collide. Where namespaces cannot be made (not root, no
`ip`, a kernel or container that refuses) it raises NetnsUnavailable saying why; the
caller skips.

With `tc`, the link gets latency on both ends: netem's fixed delay where the kernel has netem
(CONFIG_NET_SCH_NETEM), else a token bucket (tbf, in every kernel that has traffic control)
at SLOW_LINK: a packet passes at once while the bucket holds 1600 bytes of tokens, else it
waits for them, so the world's telemetry, sent in bursts, queues for a varying few ms
(measured on a veth pair: one 100-byte packet 0.54 ms round trip, a burst of ten 5.7 ms).
"""
from __future__ import annotations

import contextlib
import ipaddress
import os
import secrets
import shutil
import signal
import subprocess
from collections.abc import Iterator
from dataclasses import dataclass

SUBNETS = ipaddress.ip_network("10.211.0.0/16")     # private; each pair takes one /30 of it
SLOW_LINK = ("tbf", "rate", "2mbit", "burst", "1600", "latency", "1s")    # queue up to 1 s: no drops


class NetnsUnavailable(Exception):
    """Network namespaces cannot be made here; the message says why."""


@dataclass(frozen=True)
class Host:
    netns: str
    dev: str        # its end of the veth pair
    addr: str       # its IPv4 address on the pair's /30

    def prefix(self) -> list[str]:
        """The command prefix that runs a program on this host."""
        return ["ip", "netns", "exec", self.netns]


@dataclass(frozen=True)
class HostPair:
    a: Host
    b: Host
    latency: str            # what delays the link on each end: "netem delay 2ms", "tbf rate 2mbit ...", or "none (why)"


def subnet(index: int) -> tuple[str, str]:
    """The two host addresses of /30 number `index` (mod the pool) of SUBNETS."""
    nets = 1 << (30 - SUBNETS.prefixlen)
    net = ipaddress.ip_network((int(SUBNETS.network_address) + 4 * (index % nets), 30))
    a, b = list(net.hosts())
    return str(a), str(b)


def _ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=10)


def _must(*args: str) -> None:
    r = _ip(*args)
    if r.returncode != 0:
        raise NetnsUnavailable(f"`ip {' '.join(args)}` failed: {r.stderr.strip() or r.returncode}")


def stop_everything_in(netns: str) -> None:
    """SIGKILL every process still in `netns` (only this run's processes can be in it)."""
    r = _ip("netns", "pids", netns)
    for word in r.stdout.split():
        with contextlib.suppress(ValueError, ProcessLookupError):
            os.kill(int(word), signal.SIGKILL)


def _slow_down(a: Host, b: Host, delay: str) -> str:
    """Put latency on both ends of the pair; says what it put, or why none."""
    if shutil.which("tc") is None:
        return "none (no `tc` command)"
    refused = []
    for qdisc in (("netem", "delay", delay), SLOW_LINK):
        rs = [subprocess.run(["tc", "-n", h.netns, "qdisc", "replace", "dev", h.dev, "root", *qdisc],
                             capture_output=True, text=True, timeout=10) for h in (a, b)]
        bad = [r.stderr.strip() or str(r.returncode) for r in rs if r.returncode != 0]
        if not bad:
            return " ".join(qdisc)
        refused.append(f"{qdisc[0]}: {bad[0]}")
    return f"none ({'; '.join(refused)})"


@contextlib.contextmanager
def two_hosts(delay: str = "2ms") -> Iterator[HostPair]:
    if os.geteuid() != 0:
        raise NetnsUnavailable("network namespaces need root (CAP_SYS_ADMIN and CAP_NET_ADMIN)")
    if shutil.which("ip") is None:
        raise NetnsUnavailable("no `ip` command (iproute2)")
    token = f"{os.getpid():x}{secrets.token_hex(2)}"         # <= 10 characters: veth names <= 15
    addr_a, addr_b = subnet(secrets.randbelow(1 << 14) ^ os.getpid())
    a = Host(f"towerlink-{token}-a", f"tlv{token}a", addr_a)
    b = Host(f"towerlink-{token}-b", f"tlv{token}b", addr_b)
    made: list[str] = []
    try:
        for h in (a, b):
            _must("netns", "add", h.netns)
            made.append(h.netns)
        _must("link", "add", a.dev, "type", "veth", "peer", "name", b.dev)
        for h in (a, b):
            _must("link", "set", h.dev, "netns", h.netns)
            _must("-n", h.netns, "addr", "add", f"{h.addr}/30", "dev", h.dev)
            _must("-n", h.netns, "link", "set", "lo", "up")     # each host's own 127.0.0.1
            _must("-n", h.netns, "link", "set", h.dev, "up")
            _must("netns", "exec", h.netns, "true")         # e.g. a container that cannot remount /sys
        yield HostPair(a, b, _slow_down(a, b, delay))
    finally:
        for ns in made:
            stop_everything_in(ns)
            _ip("netns", "del", ns)         # takes its end of the veth, and with it the pair
        if _ip("link", "show", a.dev).returncode == 0:
            _ip("link", "del", a.dev)       # the pair was made but never moved
