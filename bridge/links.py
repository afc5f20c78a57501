"""MAVLink endpoints for the bridge: non-blocking sockets, cut into packets as they arrive.

:class:`Link` is one endpoint named by a pymavlink connection string (``udpin:H:P``,
``udpout:H:P``, ``udp:H:P`` = udpin, ``tcp:H:P`` client with reconnect, ``tcpin:H:P``
server). Sockets are non-blocking and are served by the caller's ``selectors`` loop:
``fileobjs()`` to register, ``on_readable(sock)`` to get packets, ``send(bytes)`` to
write. Each socket's bytes go through its own common.mavlink.frame_parser.FrameParser
(MAVLink 1 and 2, CRC-checked, not decoded; what is not a packet is counted in
``malformed`` and skipped).

udpin links answer their peers (common.mavlink.peers: silent for more than 30 s wall, dropped;
at most 64, the most recent kept), added only for a datagram holding a valid packet
that passes ``Link.verify`` when one is set (MAVLink 2 signing on the tower link);
udpout links send to their address and accept replies from anyone. A packet that fails
``verify`` is still returned, marked ``refused`` with the reason, so the caller can
answer it (to ``addr`` only) and drop it.
"""
from __future__ import annotations

import socket
import time
from dataclasses import dataclass

from common.mavlink.dialect import towerlink as _tl
from common.mavlink.frame_parser import FrameParser, MsgInfo, Packet, message_table
from common.mavlink.peers import PeerTable
from common.mavlink.endpoints import parse_connection as parse_url

TCP_RETRY = 1.0
BATCH_BYTES = 1400      # a coalesced datagram stays within a 1500-byte Ethernet MTU

#: the towerlink dialect's messages, as the frame parser needs them
MSG_TABLE: dict[int, MsgInfo] = message_table(_tl.mavlink_map)



def handle_guarded(on, link: "Link", pkt: Packet, warn_once) -> None:
    """on(link, pkt), where an exception costs that packet only: counted as malformed on the link
    and warned about once, never stopping the bridge."""
    try:
        on(link, pkt)
    except Exception as exc:  # noqa: BLE001 - never let one packet stop the bridge
        link.stats.malformed += 1
        warn_once("packet-error", f"packet {pkt.msgid} from {link.name} failed: {exc!r}")

def _parser() -> FrameParser:
    return FrameParser(MSG_TABLE)


@dataclass
class LinkStats:
    rx_packets: int = 0
    tx_packets: int = 0
    malformed: int = 0
    unroutable: int = 0
    translated: int = 0
    deferred: int = 0
    send_errors: int = 0
    unsigned: int = 0               # signing on: unsigned packets dropped
    bad_signature: int = 0          # signing on: wrong key, replayed or stale, dropped
    refused: int = 0                # static transforms refused (bridge.trust)


class Link:
    """One MAVLink endpoint on non-blocking sockets."""

    def __init__(self, name: str, url: str, clock=time.monotonic) -> None:
        self.name = name
        self.url = url
        self.kind, self.host, self.port = parse_url(url)
        self._datagrams = self.kind in ("udpin", "udpout")     # queue() coalesces; streams send at once
        self.clock = clock
        self.stats = LinkStats()
        self._pending: list[bytes] = []       # queued packets (queue/flush)
        self._pending_bytes = 0
        self.sysids: set[int] = set()          # systems seen behind this link
        self.peers = PeerTable()               # udpin: who gets what we send
        self.verify = None                     # (Packet) -> None or the reason it is refused
        self._framers: dict[object, FrameParser] = {}
        self._tcp_clients: list[socket.socket] = []
        self._retry_at = 0.0
        self._connecting = False
        self.sock: socket.socket | None = None
        self._open()

    # ------------------------------------------------------------------ sockets
    def _open(self) -> None:
        addr = (self.host, self.port)
        if self.kind in ("udpin", "udpout"):
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.setblocking(False)
            try:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 21)
            except OSError:
                pass
            if self.kind == "udpin":
                s.bind(addr)
            else:
                s.bind(("0.0.0.0" if self.host not in ("127.0.0.1", "localhost") else "127.0.0.1", 0))
            self.sock = s
            self._framers[s] = _parser()
        elif self.kind == "tcpin":
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(addr)
            s.listen(8)
            s.setblocking(False)
            self.sock = s
        else:  # tcp client
            self.sock = None
            self._try_connect()

    def _try_connect(self) -> None:
        now = self.clock()
        if now < self._retry_at:
            return
        self._retry_at = now + TCP_RETRY
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        s.setblocking(False)
        try:
            s.connect((self.host, self.port))
        except BlockingIOError:
            pass
        except OSError:
            s.close()
            return
        self.sock = s
        self._connecting = True
        self._framers = {s: _parser()}

    def fileobjs(self) -> list[socket.socket]:
        """Sockets to watch for reading now (changes for tcp/tcpin; re-query each loop)."""
        out = [self.sock] if self.sock is not None else []
        out.extend(self._tcp_clients)
        return out

    def poll(self) -> None:
        """Periodic upkeep: reconnect tcp clients, drop silent UDP peers."""
        if self.kind == "tcp" and self.sock is None:
            self._try_connect()
        elif self.kind == "udpin":
            self.peers.expire(self.clock())

    def _check(self, pkts: list[Packet], addr=None) -> bool:
        """Mark the packets `verify` refuses (counted); True if any passed."""
        if self.verify is None:
            for p in pkts:
                p.addr = addr
            return bool(pkts)
        ok = False
        for p in pkts:
            p.addr = addr
            why = self.verify(p)
            if why is None:
                ok = True
            else:
                p.refused = why
                if why == "unsigned":
                    self.stats.unsigned += 1
                else:
                    self.stats.bad_signature += 1
        return ok

    def _drop_tcp(self, s: socket.socket) -> None:
        try:
            s.close()
        except OSError:
            pass
        self._framers.pop(s, None)
        if s in self._tcp_clients:
            self._tcp_clients.remove(s)
        if s is self.sock and self.kind == "tcp":
            self.sock = None
            self._connecting = False

    @property
    def malformed(self) -> int:
        return self.stats.malformed + sum(f.malformed for f in self._framers.values())

    def on_readable(self, s: socket.socket, budget: int = 256) -> list[Packet]:
        """Read what is waiting on socket `s` (UDP: at most `budget` datagrams; `drained`
        says whether it read them all); return the valid packets."""
        out: list[Packet] = []
        self.drained = True
        if self.kind in ("udpin", "udpout"):
            fr = self._framers[s]
            for _ in range(budget):
                try:
                    data, addr = s.recvfrom(65535)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:   # ICMP port unreachable reported on a later read, etc.
                    continue
                pkts = fr.feed(data, datagram=True)
                if self._check(pkts, addr) and self.kind == "udpin":
                    self.peers.heard(addr, self.clock())
                out.extend(pkts)
            else:
                self.drained = False
        elif self.kind == "tcpin" and s is self.sock:
            while True:
                try:
                    c, _addr = s.accept()
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    break
                c.setblocking(False)
                c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._tcp_clients.append(c)
                self._framers[c] = _parser()
        else:
            fr = self._framers.get(s)
            if fr is None:
                return out
            try:
                data = s.recv(65536)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:
                self._fold(fr)
                self._drop_tcp(s)
                return out
            if not data:
                self._fold(fr)
                self._drop_tcp(s)
                return out
            self._connecting = False
            pkts = fr.feed(data)
            self._check(pkts)
            out.extend(pkts)
        self.stats.rx_packets += len(out)
        for p in out:
            self.sysids.add(p.sysid)
        return out

    def _fold(self, fr: FrameParser) -> None:
        self.stats.malformed += fr.malformed + (1 if fr.buf else 0)

    def queue(self, data: bytes) -> None:
        """Send one packet with the next ones in one datagram (UDP; up to BATCH_BYTES), written
        by flush() or before the next send(), so order is kept. Forwarded telemetry goes this
        way: one sendto costs about 10 us on loopback, as much as the rest of the forwarding."""
        if not self._datagrams:
            self.send(data)
            return
        n = self._pending_bytes + len(data)
        if n > BATCH_BYTES:
            self.flush()
            n = len(data)
        self._pending.append(data)
        self._pending_bytes = n

    def flush(self) -> None:
        """Write the queued packets now (one datagram)."""
        if self._pending:
            data, n = b"".join(self._pending), len(self._pending)
            self._pending.clear()
            self._pending_bytes = 0
            self._write(data, n)

    def send(self, data: bytes) -> None:
        """Write one packet now, after what is queued (best effort; UDP drops, a broken TCP
        link reconnects)."""
        if self._pending:
            self.flush()
        self._write(data, 1)

    def _write(self, data: bytes, n: int) -> None:
        st = self.stats
        if self.kind == "udpout":
            try:
                self.sock.sendto(data, (self.host, self.port))
                st.tx_packets += n
            except OSError:
                st.send_errors += 1
        elif self.kind == "udpin":
            sent = False
            for addr in self.peers.addrs():
                try:
                    self.sock.sendto(data, addr)
                    sent = True
                except OSError:
                    st.send_errors += 1
            if sent:
                st.tx_packets += n
        else:
            targets = self._tcp_clients if self.kind == "tcpin" else ([self.sock] if self.sock else [])
            for s in list(targets):
                try:
                    s.sendall(data)  # small packets; non-blocking send of a few hundred bytes
                except (BlockingIOError, InterruptedError):
                    st.send_errors += 1
                except OSError:
                    if self._connecting:
                        continue
                    fr = self._framers.get(s)
                    if fr is not None:
                        self._fold(fr)
                    self._drop_tcp(s)
                    st.send_errors += 1
                else:
                    st.tx_packets += n

    def reply(self, addr, data: bytes) -> None:
        """Send to one UDP address that is not (yet) a peer, e.g. a refusal's answer."""
        if addr is None or self.sock is None or self.kind not in ("udpin", "udpout"):
            return
        try:
            self.sock.sendto(data, addr)
            self.stats.tx_packets += 1
        except OSError:
            self.stats.send_errors += 1

    @property
    def connected(self) -> bool:
        if self.kind == "udpout":
            return True
        if self.kind == "udpin":
            return bool(self.peers)
        if self.kind == "tcpin":
            return bool(self._tcp_clients)
        return self.sock is not None and not self._connecting

    def close(self) -> None:
        for s in self.fileobjs():
            try:
                s.close()
            except OSError:
                pass
        self._tcp_clients.clear()
        self.sock = None
