"""MAVLink endpoints on one asyncio event loop, named by pymavlink connection strings.

  udpin:HOST:PORT    listen; every peer that has sent a valid packet gets everything the
                     vehicle sends, until it has been silent PEER_TIMEOUT (30) wall seconds;
                     at most MAX_PEERS (64) peers, the most recently heard kept
  udpout:HOST:PORT   push to a listener (a GCS on 14550, MAVSDK on 14540); its replies are read
  tcpin:HOST:PORT    TCP server (ArduPilot SITL's 5760): several clients at once

An endpoint hands each received chunk to `on_data(data, channel)`; a channel is where a
reply goes (one UDP peer, one TCP client, or the udpout target). `send(buf)` goes to all.
`on_data` returns True when the chunk held a packet that passed the link's checks (CRC and,
with signing on, the signature): only then does a UDP sender become a peer, so garbage,
forged or unsigned packets never subscribe anyone to the telemetry stream.

Every write goes through the endpoint's `outbox` (vehicle/link/outbox.py): the world holds
them while it steps and writes them when it yields.
"""
from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Callable

from common.mavlink.endpoints import parse_connection
from common.mavlink.peers import MAX_PEERS, PEER_TIMEOUT, PeerTable
from vehicle.link.outbox import DIRECT, Outbox

VEHICLE_KINDS = ("udpin", "udpout", "tcpin")
Handler = Callable[[bytes, "Channel"], "bool | None"]



def parse_endpoint(spec: str) -> tuple[str, str, int]:
    """'udpin:127.0.0.1:14560' -> ('udpin', '127.0.0.1', 14560); an empty host listens on all
    interfaces. The kinds a vehicle serves; raises ValueError (common.mavlink.endpoints does the parsing)."""
    return parse_connection(spec, kinds=VEHICLE_KINDS, default_host="0.0.0.0")


class Channel:
    """One reply path. `stream` is True for TCP (a parser keeps state across chunks)."""

    def __init__(self, name: str, sender: Callable[[bytes], None], stream: bool = False) -> None:
        self.name = name
        self._send = sender
        self.stream = stream
        self.closed = False         # the peer was dropped (its queued replies are discarded)

    def close(self) -> None:
        """The peer is gone: what is queued for it is dropped, nothing more is sent."""
        self.closed = True

    def send(self, buf: bytes) -> None:
        try:
            self._send(buf)
        except (OSError, RuntimeError):
            pass

    def __repr__(self) -> str:
        return f"<Channel {self.name}>"


class Endpoint:
    """`tx_bytes` / `rx_bytes`: what it has written and read since it started (every peer's
    copy of a broadcast counts), for the port report of @SYS/uarts.txt."""
    spec = ""
    tx_bytes = 0
    rx_bytes = 0

    async def start(self) -> None: ...
    def send(self, buf: bytes) -> None: ...

    def listened(self) -> bool:
        """False when nobody can receive what send() would send now (a udpin with no peer, a
        TCP server with no client): the link then builds no streams for it."""
        return True
    def close(self) -> None: ...


class _UdpProto(asyncio.DatagramProtocol):
    def __init__(self, owner) -> None:
        self.owner = owner

    def datagram_received(self, data: bytes, addr) -> None:
        self.owner.received(data, addr)

    def error_received(self, exc) -> None:   # ICMP port unreachable from a gone peer: ignore
        pass


class UdpIn(Endpoint):
    """Listen; reply to every peer that has sent a valid packet (like ArduPilot's udpin /
    MAVProxy), dropping peers silent for `peer_timeout` wall seconds and keeping at most
    `max_peers` (the most recently heard). Wall time, not sim time: a peer's silence is a
    fact about the network, and a paused or slowed world must not keep dead peers alive."""

    def __init__(self, host: str, port: int, on_data: Handler, peer_timeout: float = PEER_TIMEOUT,
                 max_peers: int = MAX_PEERS, clock: Callable[[], float] = time.monotonic,
                 outbox: Outbox = DIRECT) -> None:
        self.spec = f"udpin:{host}:{port}"
        self.host, self.port, self.on_data = host, port, on_data
        self.outbox = outbox
        self.transport = None
        self.clock = clock
        self.peers = PeerTable(peer_timeout, max_peers)   # addr -> its reply Channel (common.mavlink.peers)
        self.next_expiry = 0.0
        self.dropped_peers = 0

    @property
    def peer_timeout(self) -> float:
        return self.peers.timeout

    @peer_timeout.setter
    def peer_timeout(self, seconds: float) -> None:
        self.peers.timeout = seconds

    @property
    def max_peers(self) -> int:
        return self.peers.max_peers

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        self.transport, _ = await loop.create_datagram_endpoint(
            lambda: _UdpProto(self), local_addr=(self.host, self.port))

    def received(self, data: bytes, addr) -> None:
        self.rx_bytes += len(data)
        ch = self.peers.get(addr)
        if ch is None:      # replies to this packet may go back; it is no peer until it checks out
            ch = Channel(f"{self.spec}<-{addr[0]}:{addr[1]}", lambda b, a=addr: self._sendto(b, a))
        if not self.on_data(data, ch):
            return
        self._closed(self.peers.heard(addr, self.clock(), ch))

    def _closed(self, dropped) -> None:
        for _addr, ch in dropped:
            ch.close()
            self.dropped_peers += 1

    def expire(self) -> None:
        """Drop the peers silent for longer than the timeout (checked at most once a second)."""
        now = self.clock()
        if now < self.next_expiry:
            return
        self.next_expiry = now + min(1.0, self.peer_timeout / 4)
        self._closed(self.peers.expire(now))

    def listened(self) -> bool:
        return self.transport is not None and len(self.peers) > 0

    def _sendto(self, buf: bytes, addr) -> None:
        self.tx_bytes += len(buf)
        self.outbox.send(self.transport.sendto, buf, addr)

    def send(self, buf: bytes) -> None:
        if self.transport is None:
            return
        self.expire()
        for addr in self.peers:
            try:
                self._sendto(buf, addr)
            except OSError:
                pass

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()


class UdpOut(Endpoint):
    """Push to HOST:PORT from an ephemeral port; replies from the target are read."""

    def __init__(self, host: str, port: int, on_data: Handler, outbox: Outbox = DIRECT) -> None:
        self.spec = f"udpout:{host}:{port}"
        self.host, self.port, self.on_data = host, port, on_data
        self.outbox = outbox
        self.transport = None
        self.channel = Channel(self.spec, self._sendto)

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setblocking(False)
        if self.host.endswith(".255"):
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        sock.bind(("0.0.0.0", 0))
        self.addr = (socket.gethostbyname(self.host), self.port)
        self.transport, _ = await loop.create_datagram_endpoint(lambda: _UdpProto(self), sock=sock)

    def _sendto(self, buf: bytes) -> None:
        if self.transport is not None:
            self.tx_bytes += len(buf)
            self.outbox.send(self.transport.sendto, buf, self.addr)

    def received(self, data: bytes, addr) -> None:
        self.rx_bytes += len(data)
        self.on_data(data, self.channel)

    def send(self, buf: bytes) -> None:
        try:
            self._sendto(buf)
        except OSError:
            pass

    def close(self) -> None:
        if self.transport is not None:
            self.transport.close()


class _TcpClient(asyncio.Protocol):
    """One TCP client of a TcpIn: its bytes go to the endpoint as they arrive (no task per
    client, so closing the server leaves nothing running for the event loop to cancel)."""

    def __init__(self, owner: "TcpIn") -> None:
        self.owner = owner
        self.channel: Channel | None = None

    def connection_made(self, transport) -> None:
        self.channel = self.owner.connected(transport)

    def data_received(self, data: bytes) -> None:
        self.owner.rx_bytes += len(data)
        self.owner.on_data(data, self.channel)

    def connection_lost(self, exc) -> None:
        self.owner.disconnected(self.channel)


class TcpIn(Endpoint):
    """TCP server; every connected client gets everything; each has its own parser."""
    MAX_BUFFERED = 1 << 20    # a client that stops reading is dropped past this

    def __init__(self, host: str, port: int, on_data: Handler, outbox: Outbox = DIRECT) -> None:
        self.spec = f"tcpin:{host}:{port}"
        self.host, self.port, self.on_data = host, port, on_data
        self.outbox = outbox
        self.server = None
        self.clients: dict[Channel, asyncio.Transport] = {}

    async def start(self) -> None:
        loop = asyncio.get_running_loop()
        self.server = await loop.create_server(lambda: _TcpClient(self), self.host, self.port,
                                               reuse_address=True)

    def connected(self, transport: asyncio.Transport) -> Channel:
        """A new client: its reply channel (asyncio sets TCP_NODELAY on TCP transports)."""
        peer = transport.get_extra_info("peername")
        ch = Channel(f"{self.spec}<-{peer[0]}:{peer[1]}" if peer else self.spec,
                     lambda b, t=transport: self._write(t, b), stream=True)
        self.clients[ch] = transport
        return ch

    def disconnected(self, ch: Channel) -> None:
        ch.close()                  # its queued replies are dropped
        self.clients.pop(ch, None)

    def _write(self, t: asyncio.Transport, buf: bytes) -> None:
        self.tx_bytes += len(buf)
        self.outbox.send(self._write_now, t, buf)

    def _write_now(self, t: asyncio.Transport, buf: bytes) -> None:
        if t.is_closing():
            return
        if t.get_write_buffer_size() > self.MAX_BUFFERED:
            t.abort()               # a client that stopped reading: dropped (connection_lost follows)
            return
        t.write(buf)

    def listened(self) -> bool:
        return bool(self.clients)

    def send(self, buf: bytes) -> None:
        for t in list(self.clients.values()):
            self._write(t, buf)

    def close(self) -> None:
        if self.server is not None:
            self.server.close()     # no new clients
        for t in list(self.clients.values()):
            t.close()               # each client's connection_lost runs on the loop's next pass


def make_endpoint(spec: str, on_data: Handler, outbox: Outbox = DIRECT) -> Endpoint:
    kind, host, port = parse_endpoint(spec)
    return {"udpin": UdpIn, "udpout": UdpOut, "tcpin": TcpIn}[kind](host, port, on_data, outbox=outbox)
