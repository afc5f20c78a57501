"""Two test hosts as Linux network namespaces joined by a veth pair (issue 11, across machines).

`two_hosts()` makes them, yields them, and removes them (and anything still running in
them) whatever happens. Names carry this process's pid and a random part, and the pair gets
its own /30, so parallel runs never collide. Where namespaces cannot be made (not root, no
`ip`, a kernel or container that refuses) it raises NetnsUnavailable saying why; the
caller skips. With `tc` and the kernel's netem a delay is put on both ends of the link.
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
    delay: str | None       # the netem delay on each end (one way), or None
    delay_note: str         # why there is no delay, when there is none


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
        note = ""
        if shutil.which("tc") is None:
            note = "no `tc` command"
        else:
            for h in (a, b):
                r = subprocess.run(["tc", "-n", h.netns, "qdisc", "add", "dev", h.dev, "root", "netem",
                                    "delay", delay], capture_output=True, text=True, timeout=10)
                if r.returncode != 0:
                    note = f"tc netem refused: {r.stderr.strip()}"
                    break
        yield HostPair(a, b, None if note else delay, note)
    finally:
        for ns in made:
            stop_everything_in(ns)
            _ip("netns", "del", ns)         # takes its end of the veth, and with it the pair
        if _ip("link", "show", a.dev).returncode == 0:
            _ip("link", "del", a.dev)       # the pair was made but never moved
