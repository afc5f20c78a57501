"""MAVLink 2 signing on a client's pymavlink connection (the key, the check, the refusals).

Everything the connection packs is signed (common.mavlink.signing.setup_signing: the wall
clock's timestamp, on the client's signing link id) and only packets signed with the same key,
fresh and in order, are accepted: common.mavlink.signing.SignatureCheck checks the signature
first, then the timestamp. Every refused packet is counted by reason (unsigned,
bad_signature, replay, stale).
"""
from __future__ import annotations

from typing import Any

from common.mavlink.signing import UNSIGNED, SignatureCheck, setup_signing
from gcs.client.errors import ClientError


class LinkSigning:
    """Signing set up on one pymavlink MAVLink object (`mav`), and what it refused."""

    def __init__(self, mav: Any, key: bytes, link_id: int) -> None:
        if len(key) != 32:
            raise ClientError(f"a MAVLink 2 signing key is 32 bytes, not {len(key)} "
                              "(common.mavlink.signing.key_from_text makes one from a passphrase or 64 hex digits)")
        if not 0 <= int(link_id) <= 255:
            raise ClientError(f"signing link_id {link_id} is not in 0..255")
        self.mav = mav
        self.link_id = int(link_id)
        self.refused: dict[str, int] = {}     # packets refused, by common.mavlink.signing's reason
        setup_signing(mav, key, self.link_id)
        mav.signing.allow_unsigned_callback = None
        # pymavlink's own check stores a new timestamp before it verifies the signature, so one
        # forged packet with a far-future stamp would lock the real sender out: ours checks the
        # signature first and shares the signing clock (what we send stays ahead of what we heard).
        # pymavlink offers no other hook than replacing its check on the MAVLink object.
        check = SignatureCheck(key, clock=mav.signing)

        def check_signature(msgbuf: bytearray, sysid: int, compid: int) -> bool:
            why = check.check(msgbuf, sysid, compid)
            if why is not None:
                self._count(why)
            return why is None

        mav.check_signature = check_signature

    def _count(self, why: str) -> None:
        self.refused[why] = self.refused.get(why, 0) + 1

    def on_bad_data(self, msg: Any) -> None:
        """A BAD_DATA pymavlink made of a packet: count an unsigned one it refused without asking us."""
        data = bytes(getattr(msg, "data", b"") or b"")
        if getattr(msg, "reason", "") == "Invalid signature" and \
                not (data[:1] == b"\xfd" and len(data) > 2 and data[2] & 1):
            self._count(UNSIGNED)

    def keep_link_id(self) -> None:
        """After each received packet: mavutil may have adopted the sender's link id; ours stays ours."""
        self.mav.signing.link_id = self.link_id

    def report(self) -> str:
        """'signing: N packet(s) refused (unsigned n, ...)', for a log line."""
        detail = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in sorted(self.refused.items()))
        return f"signing: {sum(self.refused.values())} packet(s) refused" + (f" ({detail})" if detail else "")


class SigningViews:
    """What a link tells of its signing (gcs.client.link.Link's; `signing`: its LinkSigning or None)."""

    signing: LinkSigning | None

    @property
    def signed(self) -> bool:
        return self.signing is not None

    @property
    def signing_refused(self) -> dict[str, int]:
        """Packets dropped by the signature check, by reason (common.mavlink.signing's names)."""
        return self.signing.refused if self.signing is not None else {}

    @property
    def refused(self) -> int:
        """Packets dropped by the signature check (0 without a signing key)."""
        return sum(self.signing_refused.values())

    def signing_report(self) -> str | None:
        """'signing: N packet(s) refused (unsigned n, ...)' for a log line; None without a key."""
        return self.signing.report() if self.signing is not None else None
