"""Free ports on this host, for tests, benchmarks and ``towerlink fly`` (one home for them).

A port is free when the OS lets us bind it *now*; whoever binds it next may lose a race
with another process, so a caller that can bind port 0 itself should do that instead.
"""
from __future__ import annotations

import random
import socket

#: fly's fixed ports: below Linux's ephemeral range (32768-60999), see :func:`free_fixed_udp_ports`
FIXED_PORTS = (20000, 32000)


def free_port(kind: int = socket.SOCK_DGRAM, host: str = "127.0.0.1") -> int:
    """A port the OS says is free on `host` right now (UDP by default)."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def free_ports(n: int, kind: int = socket.SOCK_DGRAM, host: str = "127.0.0.1") -> list[int]:
    """n distinct free ports, held open together while picking so they differ."""
    socks = []
    try:
        for _ in range(n):
            s = socket.socket(socket.AF_INET, kind)
            s.bind((host, 0))
            socks.append(s)
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def free_udp_ports(n: int, host: str = "127.0.0.1") -> list[int]:
    """n UDP ports free now, picked below the ephemeral range: a world of 100 vehicles opens
    100 sockets with kernel-chosen (ephemeral) ports while it binds the planned ones, and an
    ephemeral pick would take a planned port first ("Address already in use")."""
    socks = []
    lo, hi = FIXED_PORTS
    start = random.randrange(lo, hi)          # parallel runs start at different places
    try:
        for k in range(hi - lo):
            if len(socks) == n:
                break
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                s.bind((host, lo + (start - lo + k) % (hi - lo)))
            except OSError:
                s.close()
                continue
            socks.append(s)
        if len(socks) < n:
            raise OSError(f"only {len(socks)} free UDP ports in {lo}..{hi - 1}, {n} wanted")
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()
