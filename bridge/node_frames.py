"""Frames that nodes publish (common.tf2_ros), and who owns each: *pure* (no sockets, no clocks).

A node sends TOWERLINK_TRANSFORM (dynamic, or with the static flag) to a GCS-side link of
the bridge (its node link, --nodes, or the tower link). Before it enters the frame tree:

1. trust, as for a static frame over the wire (bridge.trust: signature, --trust-sysid,
   never a frame the bridge owns, a scenario frame only with --allow-redefine);
2. authority: the first trusted publisher of a child frame owns it, named
   ``node:<sysid>/<compid>``; a second publisher of that frame is refused with the owner's
   name (tf2 lets the last writer win silently; here two nodes that disagree about where a
   frame is would move every goal through it, so the second one is told and counted).

Accepted transforms go into the tree (statics also into its 1 Hz republishing) and are
republished by the loop on the bridge's stream, so every listener, tf-echo, view-frames
and the tlogs see every node's frames. Authority lasts for the bridge's life: a node that
restarts under the same sysid/compid is the same publisher.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

from common.frames import TransformStamped
from bridge.frame_tree import SCENARIO, FrameTree
from bridge.trust import StaticTrust


def publisher(sysid: int, compid: int) -> str:
    return f"node:{sysid}/{compid}"


@dataclass
class NodeFrames:
    trust: StaticTrust
    tree: FrameTree
    owners: dict = field(default_factory=dict)        # child frame -> publisher
    accepted: Counter = field(default_factory=Counter)  # publisher -> transforms taken
    refused: Counter = field(default_factory=Counter)   # reason -> count

    def verdict(self, sysid: int, compid: int, child: str, signature: str | None = None) -> str | None:
        """None if (sysid, compid) may publish `child`; else the reason (short, for STATUSTEXT)."""
        me = publisher(sysid, compid)
        owner = self.owners.get(child) or self.tree.authority(child)
        why = self.trust.verdict(sysid, child, self.tree.owned, owner, signature)
        if why is None and owner is not None and owner != me and not (
                owner == SCENARIO and self.trust.allow_redefine):
            why = f"{child!r} belongs to {owner}"
        return why

    def claimed(self, child: str) -> str | None:
        """For a TOWERLINK_STATIC_TRANSFORM request: the reason it may not set `child` (a node owns it)."""
        owner = self.owners.get(child)
        return None if owner is None else f"{child!r} belongs to {owner}"

    def accept(self, sysid: int, compid: int, ts: TransformStamped, static: bool,
               signature: str | None = None) -> tuple[str | None, bool]:
        """(reason refused or None, first time this publisher set this frame).

        Stores an accepted transform; TransformException / ValueError from the buffer
        (a loop, bad numbers) come back as the reason.
        """
        child = ts.child_frame_id
        why = self.verdict(sysid, compid, child, signature)
        me = publisher(sysid, compid)
        if why is None:
            try:
                if static:
                    self.tree.add_static(ts, me)
                else:
                    self.tree.statics.pop(child, None)   # a static turned dynamic: no longer republished as static
                    self.tree.buffer.set_transform(ts, authority=me)
            except Exception as exc:  # noqa: BLE001 - the buffer's typed errors are the reason
                why = str(exc)
        if why is not None:
            self.refused[why] += 1
            return why, False
        first = self.owners.get(child) != me
        self.owners[child] = me
        self.accepted[me] += 1
        return None, first
