"""Tower goals: where a goal in the tower's frame becomes a drone target, in one hop.

A goal arrives on the tower link as SET_POSITION_TARGET_LOCAL_NED (LOCAL_NED or
LOCAL_OFFSET_NED, in the tower frame) or TOWERLINK_POSITION_TARGET (in the frame it
names). :meth:`GoalDesk.try_goal` is the whole path::

    fresh_lookup(world <- goal frame)     # bridge.frame_tree: LATEST, never a stale chain
    -> translate (bridge.translate)       # point, vectors, heading into world
    -> pack as the tower's own packet     # same sysid, compid, seq (bridge.codec)
    -> send to the vehicle named by target_system

If the transform is missing or its dynamic chain is older than --max-transform-age the
goal is not sent: it waits (one per target system; a newer goal supersedes it), counted
as ``deferred`` on the tower link and retried every tick, with a STATUSTEXT and a log
line at most once a wall second saying why. A goal is never sent with a guess.
"""
from __future__ import annotations

from dataclasses import dataclass

from gcs.frames import TransformException
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
            T = self.tree.fresh_lookup(dst, g.frame, self.world_clock()).transform
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
