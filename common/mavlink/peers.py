"""The UDP peers of a listening link (pure: addresses and the wall times given to it).

One rule for every udpin port of the project, the vehicles' and the bridge's:
a udpin link answers every peer that wrote to it, and peers are bounded so that
short-lived or spoofed clients cannot make it send to thousands of addresses:

* a peer silent for more than ``timeout`` wall seconds (default 30 s; a GCS sends a
  HEARTBEAT every second) is dropped, the most recent one too. Wall time, not sim time:
  silence is a fact about the network, and a paused or slowed world must not keep dead
  peers alive;
* at most ``max_peers`` (64) are kept: a new peer beyond that evicts the one heard least
  recently, so the most recent ones stay;
* the link adds a peer only for a datagram that held a valid MAVLink packet and, when
  signing is on, one that passed the signature check (the links decide; this table only
  keeps the books).

Each peer may carry a value (the vehicle keeps its reply channel there); a dropped peer's
value is handed back so the link can close it.
"""
from __future__ import annotations

from collections.abc import Iterator
from typing import Any

PEER_TIMEOUT = 30.0     # wall s of silence before a UDP peer is dropped
MAX_PEERS = 64


class PeerTable:
    """Peers by address, least recently heard first."""

    def __init__(self, timeout: float = PEER_TIMEOUT, max_peers: int = MAX_PEERS) -> None:
        self.timeout = timeout
        self.max_peers = max_peers
        self._seen: dict[Any, tuple[float, Any]] = {}   # addr -> (last heard, value); dict order = age
        self.expired = 0
        self.evicted = 0

    def heard(self, addr, now: float, value: Any = None) -> list[tuple[Any, Any]]:
        """`addr` sent something acceptable at wall time `now`; returns the (addr, value)
        evicted to stay within max_peers. A known peer keeps its value unless one is given."""
        old = self._seen.pop(addr, None)
        if value is None and old is not None:
            value = old[1]
        self._seen[addr] = (now, value)         # re-inserted: the most recent is last
        out = []
        while len(self._seen) > self.max_peers:
            first = next(iter(self._seen))
            out.append((first, self._seen.pop(first)[1]))
        self.evicted += len(out)
        return out

    def expire(self, now: float) -> list[tuple[Any, Any]]:
        """Drop the peers silent for more than `timeout`; returns them as (addr, value)."""
        out = []
        for addr, (seen, value) in list(self._seen.items()):
            if now - seen <= self.timeout:
                break                           # the rest were heard more recently
            del self._seen[addr]
            out.append((addr, value))
        self.expired += len(out)
        return out

    def get(self, addr, default: Any = None) -> Any:
        item = self._seen.get(addr)
        return default if item is None else item[1]

    def addrs(self) -> list:
        return list(self._seen)

    def __iter__(self) -> Iterator:
        return iter(list(self._seen))

    def __contains__(self, addr) -> bool:
        return addr in self._seen

    def __len__(self) -> int:
        return len(self._seen)

    def __bool__(self) -> bool:
        return bool(self._seen)
