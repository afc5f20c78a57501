"""Who may change the bridge's frame tree over the wire.

A TOWERLINK_STATIC_TRANSFORM moves frames every later tower goal goes through, so the
bridge accepts one only when all of these hold, checked in this order; the first that
fails is the reason given in the answer, ``STATUSTEXT "static tf refused: <reason>"``:

1. signing: with --signing-key the packet must be MAVLink 2 signed with that key and
   fresh (common.mavlink.signing; the link marks it, reasons ``unsigned``, ``bad_signature``,
   ``replay``, ``stale``);
2. sender: its sysid is one of --trust-sysid (default 255, the tower GCS's sysid);
3. frame: a frame the bridge owns (world, each vehicle's frames) is never static, and
   a frame the scenario defined is not redefined unless --allow-redefine.

Frames added over the wire by a trusted sender may be redefined by a trusted sender.
"""
from __future__ import annotations

from dataclasses import dataclass

from bridge.frame_tree import SCENARIO


@dataclass(frozen=True)
class StaticTrust:
    trusted_sysids: frozenset = frozenset({255})
    allow_redefine: bool = False

    def verdict(self, sysid: int, child: str, owned: set, authority: str | None,
                signature: str | None = None) -> str | None:
        """None if sysid may set static frame `child`; else the reason (short, for STATUSTEXT).

        `owned`: frames the bridge owns; `authority`: who defined `child` so far (None: nobody);
        `signature`: the link's verdict on the packet's signature (None: passed or not required).
        """
        if signature is not None:
            return f"signature {signature.replace('_', ' ')}"
        if sysid not in self.trusted_sysids:
            return f"sysid {sysid} not trusted"
        if child in owned:
            return f"{child!r} is a bridge frame"
        if authority == SCENARIO and not self.allow_redefine:
            return f"{child!r} is a scenario frame"
        return None
