"""MAVLink endpoints for the bridge: framing, CRC checks and non-blocking sockets.

One idea per class:

* :class:`Framer` cuts a byte stream (or one UDP datagram) into MAVLink 1/2 packets
  without decoding payloads: header fields, CRC-16/MCRF4XX with the message's
  CRC_EXTRA, and the ``target_system``/``target_component`` bytes read straight from
  the payload (MAVLink 2 zero-truncation aware). Garbage runs, bad CRCs, truncated
  packets and unknown message ids are counted in ``malformed`` and skipped; it
  resynchronises on the next magic byte (as pymavlink's robust parser does).
* :class:`Link` is one endpoint named by a pymavlink connection string
  (``udpin:H:P``, ``udpout:H:P``, ``udp:H:P`` = udpin, ``tcp:H:P`` client with
  reconnect, ``tcpin:H:P`` server). Sockets are non-blocking and are served by the
  caller's ``selectors`` loop: ``fileobjs()`` to register, ``on_readable(sock)`` to
  get packets, ``send(bytes)`` to write.

udpin links answer their peers (bridge.peers: silent for more than 30 s wall, dropped;
at most 64, the most recent kept), added only for a datagram holding a valid packet
that passes ``Link.verify`` when one is set (MAVLink 2 signing on the tower link);
udpout links send to their address and accept replies from anyone. A packet that fails
``verify`` is still returned, marked ``refused`` with the reason, so the caller can
answer it (to ``addr`` only) and drop it.
"""
from __future__ import annotations

import binascii
import socket
import struct
import time
from dataclasses import dataclass

from common.mavlink.dialect import towerlink as _tl
from common.mavlink.peers import PeerTable
from common.mavlink.endpoints import parse_connection as parse_url

try:  # pymavlink picks fastcrc when installed
    from pymavlink.generator.mavcrc import mcrf4xx as _fast_crc
except Exception:  # pragma: no cover
    _fast_crc = None

TCP_RETRY = 1.0
MAX_STREAM_BUFFER = 1 << 20

_REV = bytes(int(f"{i:08b}"[::-1], 2) for i in range(256))


def crc_mcrf4xx(data: bytes) -> int:
    """CRC-16/MCRF4XX (MAVLink's X.25 CRC), at C speed.

    Uses fastcrc when pymavlink found it; otherwise the reflected CRC is computed as
    the bit-reversal of CRC-CCITT (binascii.crc_hqx) over bit-reversed bytes.
    """
    if _fast_crc is not None:
        return _fast_crc(bytes(data))
    c = binascii.crc_hqx(bytes(data).translate(_REV), 0xFFFF)
    return _REV[c & 0xFF] << 8 | _REV[c >> 8]


def _field_offsets(cls) -> dict[str, int]:
    """Byte offset of every wire-ordered field of a pymavlink message class."""
    fmt = cls.unpacker.format
    if isinstance(fmt, bytes):
        fmt = fmt.decode()
    tokens, num = [], ""
    for ch in fmt[1:]:
        if ch.isdigit():
            num += ch
        else:
            tokens.append(num + ch)
            num = ""
    out, pos = {}, 0
    for name, tok in zip(cls.ordered_fieldnames, tokens):
        out[name] = pos
        pos += struct.calcsize("<" + tok)
    return out


BATCH_BYTES = 1400      # a coalesced datagram stays within a 1500-byte Ethernet MTU


@dataclass(frozen=True, slots=True)
class MsgInfo:
    crc_extra: int
    target_system_ofs: int      # -1: message has no target_system
    target_component_ofs: int   # -1: none
    name: str


def _build_table(module=_tl) -> dict[int, MsgInfo]:
    table = {}
    for msgid, cls in module.mavlink_map.items():
        ofs = _field_offsets(cls)
        table[msgid] = MsgInfo(cls.crc_extra, ofs.get("target_system", -1),
                               ofs.get("target_component", -1), cls.msgname)
    return table


MSG_TABLE: dict[int, MsgInfo] = _build_table()


@dataclass(slots=True)
class Packet:
    """One CRC-checked MAVLink packet, not decoded."""
    raw: bytes
    msgid: int
    sysid: int
    compid: int
    seq: int
    target_system: int      # 0 when the message has none (broadcast)
    target_component: int
    v2: bool
    addr: object = None             # UDP sender address (a reply path that is not a peer)
    refused: str | None = None      # why Link.verify refused it (then it is not to be used)


class Framer:
    """Cut bytes into MAVLink packets; count and skip whatever is not one."""

    __slots__ = ("buf", "malformed", "packets", "_skipping", "table")

    def __init__(self, table: dict[int, MsgInfo] = MSG_TABLE) -> None:
        self.buf = bytearray()
        self.malformed = 0
        self.packets = 0
        self._skipping = False
        self.table = table

    def _bad(self) -> None:
        if not self._skipping:
            self.malformed += 1
            self._skipping = True

    def feed(self, data: bytes, datagram: bool = False) -> list[Packet]:
        """Packets found in `data` (appended to what is pending).

        datagram=True treats `data` as a whole UDP datagram: a partial packet left at
        its end is truncated input (counted), not something to wait for.
        """
        buf = self.buf
        buf += data
        out: list[Packet] = []
        i, n = 0, len(buf)
        table = self.table
        while i < n:
            magic = buf[i]
            if magic == 0xFD:
                if n - i < 10:
                    break
                plen = buf[i + 1]
                incompat = buf[i + 2]
                total = 12 + plen + (13 if incompat & 0x01 else 0)
                if incompat & ~0x01:
                    self._bad(); i += 1; continue
                if n - i < total:
                    break
                msgid = buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
                info = table.get(msgid)
                if info is None:
                    self._bad(); i += 1; continue
                end_crc = i + 10 + plen
                crc = crc_mcrf4xx(bytes(buf[i + 1:end_crc]) + bytes((info.crc_extra,)))
                if crc != (buf[end_crc] | buf[end_crc + 1] << 8):
                    self._bad(); i += 1; continue
                pay0 = i + 10
                ts = buf[pay0 + info.target_system_ofs] if 0 <= info.target_system_ofs < plen else 0
                tc = buf[pay0 + info.target_component_ofs] if 0 <= info.target_component_ofs < plen else 0
                out.append(Packet(bytes(buf[i:i + total]), msgid, buf[i + 5], buf[i + 6], buf[i + 4],
                                  ts, tc, True))
                i += total
                self._skipping = False
            elif magic == 0xFE:
                if n - i < 6:
                    break
                plen = buf[i + 1]
                total = 8 + plen
                if n - i < total:
                    break
                msgid = buf[i + 5]
                info = table.get(msgid)
                if info is None:
                    self._bad(); i += 1; continue
                end_crc = i + 6 + plen
                crc = crc_mcrf4xx(bytes(buf[i + 1:end_crc]) + bytes((info.crc_extra,)))
                if crc != (buf[end_crc] | buf[end_crc + 1] << 8):
                    self._bad(); i += 1; continue
                pay0 = i + 6
                ts = buf[pay0 + info.target_system_ofs] if 0 <= info.target_system_ofs < plen else 0
                tc = buf[pay0 + info.target_component_ofs] if 0 <= info.target_component_ofs < plen else 0
                out.append(Packet(bytes(buf[i:i + total]), msgid, buf[i + 3], buf[i + 4], buf[i + 2],
                                  ts, tc, False))
                i += total
                self._skipping = False
            else:
                self._bad()
                i += 1
        del buf[:i]
        if datagram and buf:
            self._bad()
            buf.clear()
        if datagram:
            self._skipping = False
        if len(buf) > MAX_STREAM_BUFFER:
            self._bad()
            buf.clear()
        self.packets += len(out)
        return out


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
        self.clock = clock
        self.stats = LinkStats()
        self._pending: list[bytes] = []       # queued packets (queue/flush)
        self._pending_bytes = 0
        self.sysids: set[int] = set()          # systems seen behind this link
        self.peers = PeerTable()               # udpin: who gets what we send
        self.verify = None                     # (Packet) -> None or the reason it is refused
        self._framers: dict[object, Framer] = {}
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
            self._framers[s] = Framer()
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
        self._framers = {s: Framer()}

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
        ok = False
        for p in pkts:
            p.addr = addr
            why = self.verify(p) if self.verify is not None else None
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
                self._framers[c] = Framer()
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

    def _fold(self, fr: Framer) -> None:
        self.stats.malformed += fr.malformed + (1 if fr.buf else 0)

    def queue(self, data: bytes) -> None:
        """Send one packet with the next ones in one datagram (UDP; up to BATCH_BYTES), written
        by flush() or before the next send(), so order is kept. Forwarded telemetry goes this
        way: one sendto costs about 10 us on loopback, as much as the rest of the forwarding."""
        if self.kind not in ("udpin", "udpout"):
            self.send(data)
            return
        if self._pending_bytes + len(data) > BATCH_BYTES:
            self.flush()
        self._pending.append(data)
        self._pending_bytes += len(data)

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
