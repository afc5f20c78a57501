"""The project's dialect on the wire, for the bridge: pack, re-pack, decode, transforms.

* :class:`Codec` packs the bridge's own messages (its sysid/compid, its own sequence,
  MAVLink 2 signed when a key is given), re-packs a message it translated with the
  original sender's sysid, compid, seq and protocol version, and decodes a raw packet
  (None and counted when it does not decode). Unsigned packing and all decoding go through
  common.mavlink.message_codec (pymavlink's bytes and messages, without its per-message
  overhead: the bridge packs or decodes about 17 messages per lockstep frame).
* The transform messages (TOWERLINK_TRANSFORM, TOWERLINK_STATIC_TRANSFORM) have their one
  home in common.tf2_ros.wire, shared with the nodes: frame ids at most 16 bytes (a longer id
  is a ValueError, never cut), stamps sent as microseconds.
"""
from __future__ import annotations

from common.mavlink.dialect import encoder
from common.mavlink.dialect import towerlink as tl
from common.mavlink.message_codec import MessageCodec

#: the dialect's messages to and from bytes, worked out once per process
_CODEC = MessageCodec(tl)


class Codec:
    """Bytes for the bridge's own messages and for the ones it translates."""

    def __init__(self, sysid: int, compid: int, signing_key: bytes | None = None) -> None:
        self.enc = encoder(sysid, compid)       # the bridge's own messages
        self.reenc = encoder(0, 0)              # re-encoding others' messages
        self.decode_errors = 0
        self.signed = bool(signing_key)
        if signing_key:
            from common.mavlink.signing import setup_signing
            setup_signing(self.enc, signing_key, link_id=0)
            setup_signing(self.reenc, signing_key, link_id=1)   # its own stream: no replay clash

    def pack_own(self, msg) -> bytes:
        e = self.enc
        b = msg.pack(e) if self.signed else _CODEC.pack(msg, e.seq, e.srcSystem, e.srcComponent)
        e.seq = (e.seq + 1) % 256
        return b

    def pack_as(self, msg, src: tuple) -> bytes:
        """`msg` packed as (sysid, compid, seq, v2) = the original sender's header."""
        sysid, compid, seq, v2 = src
        if not self.signed:
            return _CODEC.pack(msg, seq, sysid, compid, v2)
        e = self.reenc
        e.srcSystem, e.srcComponent, e.seq = sysid, compid, seq
        return msg.pack(e, force_mavlink1=not v2)

    def decode(self, raw: bytes):
        """The message in `raw`, or None (counted in decode_errors)."""
        try:
            return _CODEC.decode(raw)
        except Exception:
            self.decode_errors += 1
            return None


def command_message(target: int, command: int, *params):
    """COMMAND_LONG to (target, compid 1) with params padded by zeros."""
    p = [float(v) for v in params] + [0.0] * (7 - len(params))
    return tl.MAVLink_command_long_message(target, 1, command, 0, *p)


def statustext_message(text: str, severity: int = tl.MAV_SEVERITY_WARNING):
    """STATUSTEXT, cut to MAVLink's 50 characters."""
    return tl.MAVLink_statustext_message(severity, text[:50].encode())


def bridge_status_message(usec: int, name: str, stats, malformed: int):
    """TOWERLINK_BRIDGE_STATUS for one link (counters wrap at 2**32)."""
    m = 0xFFFFFFFF
    return tl.MAVLink_towerlink_bridge_status_message(
        usec, name.encode()[:16], stats.rx_packets & m, stats.tx_packets & m, malformed & m,
        stats.unroutable & m, stats.translated & m, stats.deferred & m, stats.refused & m,
        (stats.unsigned + stats.bad_signature) & m)
