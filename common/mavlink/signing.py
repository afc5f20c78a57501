"""MAVLink 2 message signing: the receiver's check, shared by the vehicles, the bridge and the
tower's client (gcs.client); the key from text (:func:`key_from_text`); a key hidden in a
command line before it is logged (:func:`masked_argv`).

A signed MAVLink 2 frame ends with 13 bytes: link_id (1), timestamp (6, little-endian,
10 us units since 2015-01-01 00:00 UTC) and the first 6 bytes of
SHA-256(secret_key + every byte before the signature). :class:`SignatureCheck` verifies
that, then the timestamp, in that order (a forged packet with a far-future timestamp
must not lock the real sender out): per stream (link_id, sysid, compid) a timestamp must
grow (else it is a replay), and a stream seen for the first time must not be more than a
minute older than the newest timestamp this receiver knows.

It works on raw bytes (``check(buf, sysid, compid)``), so a router that forwards frames
without decoding them can use it as well as a vehicle that decoded them. ``clock`` is the
receiver's signing state: any object with an integer ``timestamp`` (pymavlink's
``MAVLinkSigning``; the vehicles pass their own so what they sign and what they accept
share one clock).
"""
from __future__ import annotations

import hashlib
import struct
import time

SIGNING_EPOCH = 1420070400          # 2015-01-01; signing timestamps count 10 us from here
MAX_NEW_STREAM_AGE = 6_000_000      # 10 us units: a new stream may be a minute old at most
MAVLINK_IFLAG_SIGNED = 0x01
SIGNATURE_LEN = 13

#: reasons :meth:`SignatureCheck.check` gives (also the stats keys)
UNSIGNED, BAD_SIGNATURE, REPLAY, STALE = "unsigned", "bad_signature", "replay", "stale"


def signing_timestamp(unix_s: float | None = None) -> int:
    """Now (or `unix_s`) as a signing timestamp (10 us units since 2015-01-01)."""
    t = time.time() if unix_s is None else unix_s
    return int(max(t - SIGNING_EPOCH, 0.0) * 1e5)


_SIG_PREFIX = struct.Struct("<BQ")      # link id + timestamp; its first 7 bytes are sent


def signature(key: bytes, frame: bytes, link_id: int, timestamp: int) -> bytes:
    """The 13 bytes that sign MAVLink 2 `frame` (header to CRC, with the signed flag set):
    link_id, the 48-bit timestamp and the first 6 bytes of SHA-256(key + frame + those 7)."""
    head = _SIG_PREFIX.pack(link_id & 0xFF, timestamp)[:7]
    return head + hashlib.sha256(key + frame + head).digest()[:6]


class _Clock:
    """A signing state of its own for receivers that do not sign."""

    def __init__(self) -> None:
        self.timestamp = signing_timestamp()


def setup_signing(mav, key: bytes, link_id: int = 0) -> None:
    """Make a pymavlink ``MAVLink`` encoder sign what it packs, from the wall clock."""
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.link_id = link_id
    mav.signing.timestamp = max(mav.signing.timestamp, signing_timestamp())


class SignatureCheck:
    """Verify signed MAVLink 2 frames for one receiver (see the module docstring)."""

    def __init__(self, key: bytes, clock=None) -> None:
        if not key:
            raise ValueError("a signing key must not be empty")
        self.key = bytes(key)
        self.clock = clock if clock is not None else _Clock()
        self.last: dict[tuple[int, int, int], int] = {}     # (link_id, sysid, compid) -> timestamp

    def check(self, buf: bytes, sysid: int, compid: int) -> str | None:
        """None if `buf` (one whole frame) is signed with our key and fresh, else the reason."""
        buf = bytes(buf)
        if len(buf) < SIGNATURE_LEN or not (buf[0] == 0xFD and buf[2] & MAVLINK_IFLAG_SIGNED):
            return UNSIGNED
        if hashlib.sha256(self.key + buf[:-6]).digest()[:6] != buf[-6:]:
            return BAD_SIGNATURE
        link_id = buf[-13]
        tlow, thigh = struct.unpack("<IH", buf[-12:-6])
        ts = tlow + (thigh << 32)
        stream = (link_id, sysid, compid)
        last = self.last.get(stream)
        if last is not None and ts <= last:
            return REPLAY
        if last is None and ts + MAX_NEW_STREAM_AGE < self.clock.timestamp:
            return STALE
        self.last[stream] = ts
        self.clock.timestamp = max(self.clock.timestamp, ts)
        return None


def key_from_text(text: str | None) -> bytes | None:
    """A 32-byte signing key from 64 hex digits, or from a passphrase hashed with SHA-256
    (as MAVProxy's ``signing setup PASSPHRASE``); None for no text."""
    if not text:
        return None
    if len(text) == 64:
        try:
            return bytes.fromhex(text)
        except ValueError:
            pass
    return hashlib.sha256(text.encode()).digest()


SIGNING_FLAG = "--signing-key"
MASK = "***"
#: how every CLI describes the key it takes
KEY_FORMS = "64 hex digits, or a passphrase hashed with SHA-256 (as MAVProxy's 'signing setup')"


def add_signing_argument(parser, help: str) -> None:
    """Declare ``--signing-key PASSPHRASE|HEX64`` (default None) on an argparse parser.

    `help` says what is signed; it may use ``{forms}`` for :data:`KEY_FORMS`."""
    parser.add_argument(SIGNING_FLAG, metavar="PASSPHRASE|HEX64", default=None,
                        help=help.replace("{forms}", KEY_FORMS))


def masked_argv(argv: list[str]) -> list[str]:
    """`argv` with every --signing-key value replaced by ***, for logs and run folders.

    Handles the value as the next word, as ``--signing-key=VALUE``, and inside one word that
    holds a whole shell-quoted command line (a command handed to ssh)."""
    import re
    import shlex
    out: list[str] = []
    for i, a in enumerate(argv):
        if i > 0 and argv[i - 1] == SIGNING_FLAG:
            out.append(MASK)
        elif a.startswith(SIGNING_FLAG + "="):
            out.append(SIGNING_FLAG + "=" + MASK)
        elif SIGNING_FLAG in a and a != SIGNING_FLAG:
            try:
                words = shlex.split(a)
            except ValueError:          # not a command line: hide everything after the flag
                out.append(re.sub(re.escape(SIGNING_FLAG) + r".*", SIGNING_FLAG + " " + MASK, a, flags=re.S))
                continue
            out.append(shlex.join(masked_argv(words)))
        else:
            out.append(a)
    return out
