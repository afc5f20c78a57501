"""A client's receive path without pymavlink's per-message decode: frames cut, decoded on demand.

The tower hears the whole system's telemetry (about 15 messages per 40 ms TICK in the lab) and
reads few of them. pymavlink's ``recv_match`` decodes and files every one; :class:`LazyReceiver`
reads the connection's UDP socket itself, cuts each datagram into CRC-checked packets
(common.mavlink.frame_parser, the towerlink dialect's table) and leaves decoding to the caller,
which decodes only what it uses and reads a packet's ``time_boot_ms`` (ms, the vehicle's clock)
straight from its payload. What reaches the client is the same packets in the same order.

It serves a pymavlink ``udpout`` connection without signing (:meth:`LazyReceiver.serves`): a
``udpin`` one learns its peers in ``recv``, and signed packets are checked by pymavlink's parser.
"""
from __future__ import annotations

import select
import sys
from collections import deque
from typing import Any

from common.mavlink.frame_parser import FrameParser, MsgInfo, Packet, field_offsets, message_table
from common.mavlink.message_codec import MessageCodec
from gcs.client.tlog import Tlog

_TABLES: dict[str, tuple[dict[int, MsgInfo], dict[int, int], MessageCodec]] = {}


def _tables(module: Any) -> tuple[dict[int, MsgInfo], dict[int, int], MessageCodec]:
    """A dialect's frame table, per message id with a time_boot_ms field its payload offset, and
    its decoder."""
    name = module.__name__
    if name not in _TABLES:
        offsets = {}
        for msgid, cls in module.mavlink_map.items():
            ofs = field_offsets(cls).get("time_boot_ms")
            if ofs is not None:
                offsets[msgid] = ofs
        _TABLES[name] = (message_table(module.mavlink_map), offsets, MessageCodec(module))
    return _TABLES[name]


class LazyReceiver:
    """Packets from a pymavlink udpout connection's socket, in arrival order, undecoded."""

    def __init__(self, master: Any, tlog: Tlog | None = None) -> None:
        """`master`: a pymavlink udpout connection (see :meth:`serves`); `tlog`: where every
        packet received is recorded as it came."""
        module = sys.modules[type(master.mav).__module__]
        self.table, self._boot_ofs, self._decoder = _tables(module)
        self.master = master
        self.tlog = tlog
        self._undecoded = 0
        self.parser = FrameParser(self.table)
        self._pending: deque[Packet] = deque()
        self._bad_told = 0

    @staticmethod
    def serves(master: Any, signed: bool) -> bool:
        """Whether `master` can be read this way: a pymavlink udpout connection, no signing."""
        from gcs.client.mav import mavutil
        return (not signed and isinstance(master, mavutil.mavudp) and not master.udp_server
                and not master.broadcast)

    def next(self, timeout: float) -> Packet | None:
        """The next packet, waiting at most `timeout` wall s for a datagram; None if none came."""
        if not self._pending:
            self._fill(timeout)
        return self._pending.popleft() if self._pending else None

    def _fill(self, timeout: float) -> None:
        sock = self.master.port
        if timeout > 0 and not select.select([sock], [], [], timeout)[0]:
            return
        while True:
            try:
                data = sock.recv(65535)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:             # ICMP port unreachable reported on a later read, etc.
                return
            if self.master.first_byte:
                self.master.auto_mavlink_version(data)
            pkts = self.parser.feed(data, datagram=True)
            if self.tlog is not None:
                self.tlog.write_packets(pkts)
            self._pending.extend(pkts)

    def take_bad(self) -> int:
        """Runs of bytes that were no packet, and packets that did not decode, since the last
        call (pymavlink's BAD_DATA)."""
        now = self.parser.malformed + self._undecoded
        bad, self._bad_told = now - self._bad_told, now
        return bad

    def name(self, pkt: Packet) -> str:
        """The packet's message name (pymavlink's get_type())."""
        return self.table[pkt.msgid].name

    def decode(self, pkt: Packet) -> Any | None:
        """The pymavlink message in `pkt`, or None when it does not decode."""
        try:
            return self._decoder.decode(pkt.raw)
        except Exception:  # noqa: BLE001 - pymavlink raises its own error types
            self._undecoded += 1
            return None

    def time_boot_ms(self, pkt: Packet) -> int | None:
        """The packet's time_boot_ms (ms, little-endian u32; 0 when MAVLink 2 truncated it), or
        None when its message has no such field."""
        ofs = self._boot_ofs.get(pkt.msgid)
        if ofs is None:
            return None
        raw, start = pkt.raw, (10 if pkt.v2 else 6) + ofs
        end = min(start + 4, (10 if pkt.v2 else 6) + raw[1])
        return int.from_bytes(raw[start:end], "little") if end > start else 0
