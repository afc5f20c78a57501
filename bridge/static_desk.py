"""TOWERLINK_STATIC_TRANSFORM over the wire: judged, added and published, or refused and told.

Who may add or redefine which frame is bridge.trust's verdict; a frame a node publishes
stays the node's (bridge.node_frames). An added static goes into the tree (authority
``static-transform:<sysid>``) and out on the transform stream at once, with a STATUSTEXT
``static tf <parent>-><child> added``; a refusal is counted on the link (``refused``) and
answered ``static tf refused: <reason>`` to the GCS links, and to the sender alone when it
is not a peer of the link (so a refused sender still hears why).
"""
from __future__ import annotations

from common.frames import TransformException
from common.mavlink.dialect import towerlink as tl
from common.mavlink.frame_parser import Packet
from common.tf2_ros.wire import transform_from_message, transform_message
from bridge.codec import Codec, statustext_message
from bridge.frame_tree import FrameTree
from bridge.links import Link
from bridge.log import BridgeLog
from bridge.node_frames import NodeFrames
from bridge.router import Router
from bridge.trust import StaticTrust


class StaticDesk:
    """Live static frames from the GCS side: trust, then the tree and the stream."""

    def __init__(self, trust: StaticTrust, tree: FrameTree, node_frames: NodeFrames, codec: Codec,
                 router: Router, log: BridgeLog) -> None:
        self.trust = trust
        self.tree = tree
        self.node_frames = node_frames
        self.codec = codec
        self.router = router
        self.log = log.log

    def on_static(self, link: Link, pkt: Packet, msg) -> None:
        """A TOWERLINK_STATIC_TRANSFORM (`msg` None: it did not decode) from `link`."""
        try:
            ts = transform_from_message(msg)[0] if msg is not None else None
            why = self.trust.verdict(pkt.sysid, ts.child_frame_id if ts else "", self.tree.owned,
                                     self.tree.authority(ts.child_frame_id) if ts else None, pkt.refused)
            if why is None and ts is not None:
                why = self.node_frames.claimed(ts.child_frame_id)     # a node's frame stays the node's
            if why is None:
                ts = self.tree.add_static(ts, f"static-transform:{pkt.sysid}")
        except (TransformException, ValueError) as exc:
            why = str(exc)
        if why is not None:
            link.stats.refused += 1
            self.log(f"static transform from sysid {pkt.sysid} refused: {why}")
            text = statustext_message(f"static tf refused: {why}", tl.MAV_SEVERITY_ERROR)
            if pkt.addr is not None and pkt.addr not in link.peers:
                link.reply(pkt.addr, self.codec.pack_own(text))    # not a peer: answer it alone
            self.router.send_own_to_gcs(text)
            return
        self.log(f"static transform {ts.frame_id} -> {ts.child_frame_id} added by sysid {pkt.sysid}")
        self.router.statustext(f"static tf {ts.frame_id}->{ts.child_frame_id} added", tl.MAV_SEVERITY_INFO)
        self.router.send_own_to_gcs(transform_message(ts, static=True))
