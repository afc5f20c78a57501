"""Tower goals: where a goal in the tower's frame becomes a drone target, in one hop.

A goal arrives on the tower link as SET_POSITION_TARGET_LOCAL_NED (LOCAL_NED or
LOCAL_OFFSET_NED, in the tower frame) or TOWERLINK_POSITION_TARGET (in the frame it
names). :meth:`GoalDesk.try_goal` is the whole path::

    fresh_lookup(<name>_origin <- goal frame)   # the target's local frame; LATEST, never stale
    -> translate (bridge.translate)       # point, vectors, heading into world
    -> pack as the tower's own packet     # same sysid, compid, seq (bridge.codec)
    -> send to the vehicle named by target_system

A goal stamped by the tower (time_boot_ms > 0, mapped onto the one timeline) whose
frame hangs on a moving vehicle (the tower on the van) is resolved at that stamp:
``lookup_transform_full(world, t, frame, t, fixed_frame=world)``, tf2's time travel, so a
goal means where the tower pointed when it spoke, not where its frame is when the goal
arrives. The world transform found for (target, frame, stamp) is kept, so a goal re-sent
with the same stamp lands on the same point however long it has been. The log says how
far the latest transform would have put it.

If the transform is missing or its dynamic chain is older than --max-transform-age the
goal is not sent: it waits (one per target system; a newer goal supersedes it), counted
as ``deferred`` on the tower link and retried every tick, with a STATUSTEXT and a log
line at most once a wall second saying why. A goal is never sent with a guess.
"""
from __future__ import annotations

from dataclasses import dataclass

import math

from common.frames import ExtrapolationException, TransformException
from bridge import translate
from bridge.frame_tree import FrameTree, StaleTransform


@dataclass
class PendingGoal:
    kind: str                # "spt" (SET_POSITION_TARGET_LOCAL_NED) or "named"
    msg: object
    src: tuple               # (sysid, compid, seq, v2) of the tower's packet
    frame: str               # the frame the goal is written in
    target: int              # target_system
    since: float             # bridge wall time it arrived
    stamp: float | None = None   # the tower's stamp (s, one timeline); None: resolve at LATEST
    last_warn: float = -1e9
    attempts: int = 0


class GoalDesk:
    def __init__(self, tree: FrameTree, codec, send, stats, world_clock, clock, log, statustext,
                 world_frame: str = "world", frame_of=None) -> None:
        self.tree = tree
        self.codec = codec
        self._send = send                   # (target_system, bytes) -> bool (reached a vehicle)
        self.stats = stats                  # the tower link's LinkStats
        self.world_clock = world_clock      # () -> newest vehicle clock, s, one timeline
        self.clock = clock
        self.log = log
        self.statustext = statustext
        self.world_frame = world_frame
        # target_system -> the frame its local NED is in (<vehicle>_origin; world if unknown)
        self.frame_of = frame_of or (lambda target: world_frame)
        self.pending: dict[int, PendingGoal] = {}
        self.resolved: dict[int, tuple] = {}     # target -> ((frame, stamp), world <- frame)
        self.time_travel: list[tuple[int, float, float]] = []   # (target, stamp, m moved by LATEST)

    def submit(self, g: PendingGoal) -> None:
        self.pending[g.target] = g          # a newer goal supersedes a waiting one
        self.try_goal(g)

    def retry(self) -> None:
        for g in list(self.pending.values()):
            self.try_goal(g)

    def try_goal(self, g: PendingGoal) -> bool:
        """Translate `g` into the target's local frame (its <name>_origin) and send it, or
        leave it pending; True if sent."""
        g.attempts += 1
        dst = self.frame_of(g.target)
        try:
            T = self._resolve(g)
        except (TransformException, StaleTransform) as exc:
            self.stats.deferred += 1
            now = self.clock()
            if now - g.last_warn >= 1.0:
                g.last_warn = now
                self.log(f"goal for sysid {g.target} in {g.frame!r} waits: {exc}")
                self.statustext(f"goal waits: no {g.frame}->{dst} tf")
            return False
        out = translate.set_position_target(g.msg, T) if g.kind == "spt" else translate.named_target(g.msg, T)
        if self._send(g.target, self.codec.pack_as(out, g.src)):
            self.stats.translated += 1
        else:
            self.stats.unroutable += 1
        if self.pending.get(g.target) is g:
            del self.pending[g.target]
        if g.attempts > 1:
            self.log(f"goal for sysid {g.target} in {g.frame!r} sent after {g.attempts} attempts")
        return True

    def _resolve(self, g: PendingGoal):
        """dst <- g.frame for this goal, dst the target's local frame (<name>_origin): at its
        stamp when the chain moves, else LATEST."""
        dst = self.frame_of(g.target)
        key = (g.frame, g.stamp)
        memo = self.resolved.get(g.target)
        if g.stamp is not None and memo is not None and memo[0] == key:
            return memo[1]                  # a re-send of a goal already placed in world
        newest = self.tree.fresh_lookup(dst, g.frame, self.world_clock())
        latest = newest.transform
        if g.stamp is None or not self.tree.is_dynamic(dst, g.frame):
            return latest
        if g.stamp > newest.stamp:
            raise ExtrapolationException(f"goal stamped {g.stamp:.3f} s; {g.frame} known up to "
                                         f"{newest.stamp:.3f} s: waiting for it")
        try:
            T = self.tree.buffer.lookup_transform_full(dst, g.stamp, g.frame, g.stamp,
                                                       self.world_frame).transform
        except ExtrapolationException as exc:
            # stamped before the frame's kept history (before it appeared, or older than
            # --cache-time): the stamp cannot be honoured; the goal goes where the frame is now
            self.log(f"goal for sysid {g.target} in {g.frame!r}: its stamp {g.stamp:.3f} s is "
                     f"before the transform history ({exc}); resolved with the latest")
            return latest
        self.resolved[g.target] = (key, T)
        p = (float(g.msg.x), float(g.msg.y), float(g.msg.z))
        if all(math.isfinite(v) for v in p):
            moved = float(math.dist(T.apply_point(p), latest.apply_point(p)))
            self.time_travel.append((g.target, g.stamp, moved))
            del self.time_travel[:-256]
            self.log(f"goal for sysid {g.target} in {g.frame!r} resolved at its stamp {g.stamp:.3f} s; "
                     f"the latest transform would put it {moved:.2f} m away")
        return T
