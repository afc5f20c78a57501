"""The UDP peers of a listening link (pure: addresses and the times given to it).

A udpin link answers every peer that wrote to it. Peers are bounded so that short-lived
or spoofed clients cannot make the bridge send to thousands of addresses (issue 8):

* a peer silent for more than ``timeout`` wall seconds (default 30 s, the vehicles' UDP
  ports use the same) is dropped, the most recent one too;
* at most ``max_peers`` (64) are kept: a new peer beyond that evicts the one heard least
  recently, so the most recent ones stay;
* the link adds a peer only for a datagram that held a valid MAVLink packet and, when
  signing is on, one that passed the signature check (bridge.links).
"""
from __future__ import annotations

PEER_TIMEOUT = 30.0     # wall s of silence before a UDP peer is dropped
MAX_PEERS = 64


class PeerTable:
    def __init__(self, timeout: float = PEER_TIMEOUT, max_peers: int = MAX_PEERS) -> None:
        self.timeout = timeout
        self.max_peers = max_peers
        self._seen: dict[tuple, float] = {}     # addr -> last heard (wall s), oldest first
        self.expired = 0
        self.evicted = 0

    def heard(self, addr, now: float) -> None:
        """`addr` sent something acceptable at wall time `now`."""
        self._seen.pop(addr, None)
        self._seen[addr] = now                  # re-inserted: dict order = least recent first
        while len(self._seen) > self.max_peers:
            del self._seen[next(iter(self._seen))]
            self.evicted += 1

    def expire(self, now: float) -> int:
        """Drop peers silent for more than `timeout`; how many were dropped."""
        n = 0
        for addr, seen in list(self._seen.items()):
            if now - seen <= self.timeout:
                break                           # the rest were heard more recently
            del self._seen[addr]
            n += 1
        self.expired += n
        return n

    def addrs(self) -> list:
        return list(self._seen)

    def __contains__(self, addr) -> bool:
        return addr in self._seen

    def __len__(self) -> int:
        return len(self._seen)

    def __bool__(self) -> bool:
        return bool(self._seen)
