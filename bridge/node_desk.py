"""The node link's traffic in the bridge: nodes' transforms in, tower goals out (--route-only).

* A node's TOWERLINK_TRANSFORM -> :class:`bridge.node_frames.NodeFrames` (trust, then the
  frame's authority) -> the tree -> the bridge's stream (to the tower, the outs and the
  node link, so each node's listener sees every other node's frames). A refusal is
  counted on the link (``refused``, in TOWERLINK_BRIDGE_STATUS) and told as STATUSTEXT
  ``tf refused: <reason>`` (to the GCS links, and to the sender when it is not a peer),
  at most every 5 s per sender and frame, since a node streams at its own rate.
* With --route-only a tower goal in the tower frame goes, as received, to the node link:
  a node (the lab's tower_to_map) transforms it and sends the drone a world goal.
"""
from __future__ import annotations

from common.frames import TransformException
from common.mavlink.dialect import towerlink as tl
from common.mavlink.frame_parser import Packet
from common.mavlink.mavstr import mav_str
from common.tf2_ros.wire import transform_from_message, transform_message
from bridge.codec import Codec, statustext_message
from bridge.frame_tree import FrameTree
from bridge.links import Link
from bridge.log import BridgeLog
from bridge.node_frames import NodeFrames, publisher
from bridge.router import Router
from bridge.trust import StaticTrust

REFUSAL_TELL_PERIOD = 5.0       # wall s between STATUSTEXTs for one sender and frame


class NodeDesk:
    def __init__(self, trust: StaticTrust, tree: FrameTree, node_links: list[Link], codec: Codec,
                 router: Router, log: BridgeLog) -> None:
        self.frames = NodeFrames(trust, tree)
        self.node_links = node_links
        self.codec = codec
        self.send_own_to_gcs, self.statustext = router.send_own_to_gcs, router.statustext
        self.log, self.warn_once = log.log, log.warn_once

    def on_transform(self, link: Link, pkt: Packet, msg) -> None:
        """TOWERLINK_TRANSFORM from a node: judged, stored, republished; or refused and told."""
        if msg is None:
            return
        try:
            ts, static = transform_from_message(msg)
        except (TransformException, ValueError) as exc:
            why, first = str(exc), False
        else:
            why, first = self.frames.accept(pkt.sysid, pkt.compid, ts, static, pkt.refused)
        who = publisher(pkt.sysid, pkt.compid)
        if why is not None:
            link.stats.refused += 1
            child = mav_str(msg.child_frame_id)
            if self.warn_once(f"tf-refused:{who}:{child}", f"transform {child!r} from {who} refused: {why}",
                              REFUSAL_TELL_PERIOD):
                text = statustext_message(f"tf refused: {why}", tl.MAV_SEVERITY_ERROR)
                if pkt.addr is not None and pkt.addr not in link.peers:
                    link.reply(pkt.addr, self.codec.pack_own(text))    # not a peer: answer it alone
                self.send_own_to_gcs(text)
            return
        if first:
            self.log(f"{'static ' if static else ''}transform {ts.frame_id} -> {ts.child_frame_id} "
                     f"published by {who}")
            self.statustext(f"tf {ts.frame_id}->{ts.child_frame_id} by {who}", tl.MAV_SEVERITY_INFO)
        if first or not static:         # statics are also republished at 1 Hz with the tree's
            self.send_own_to_gcs(transform_message(ts, static=static))

    def tower_goal(self, link: Link, pkt: Packet) -> None:
        """--route-only: a tower goal (tower frame) goes, raw, to the nodes."""
        if not any(n.connected for n in self.node_links):
            link.stats.unroutable += 1
            self.warn_once("goal-no-node", "tower goal not routed: no node on the node link")
            return
        for n in self.node_links:
            n.send(pkt.raw)
