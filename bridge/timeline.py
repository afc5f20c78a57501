"""One timeline for vehicles that run on different clocks (pure: no sockets, no clocks).

Every vehicle stamps its telemetry with its own boot clock (``time_boot_ms``). Vehicles
of one SITL world share that clock; a vehicle started in its own process or on its own
host does not: its boot clock starts when its process starts. Its SYSTEM_TIME tells the
bridge where that clock sits in absolute time::

    offset_v = time_unix_usec / 1e6 - time_boot_ms / 1000     # s, "unix time at boot"

(a towerlink vehicle sends time_unix_usec = unix time at its world's start + sim
seconds, so offset_v is exactly its world's start). The first vehicle whose clock the
bridge sees is the reference; its boot clock *is* the bridge's timeline, and every
other vehicle's stamp is mapped onto it::

    stamp_ref = boot_v + offset_v - offset_ref

Vehicles of one world have the same offset (up to time_boot_ms's millisecond
truncation, ``same_world_tol``), so their stamps pass through unchanged.

Until both its offset and the reference's are known, a vehicle's timeline is unknown:
:meth:`Timeline.shift` is None and the caller holds its stamps back (the bridge queues
them and asks for SYSTEM_TIME; a towerlink, ArduPilot or PX4 vehicle streams it). A
vehicle that stays silent about its clock for ``grace`` wall seconds (a peer without
SYSTEM_TIME) can only be taken to share the reference's world: :meth:`Timeline.expire`
then presumes so (its stamps pass raw) until offsets arrive. A vehicle whose boot clock
goes back by more than ``reboot_jump`` has restarted: its offset and presumption are
forgotten (for the reference, everyone's presumptions too, since the timeline moved).

The timeline is the one owner of vehicle clocks in the bridge, so the rule "the clock
went back" (:func:`clock_went_back`) is decided here and nowhere else: on a vehicle's raw
boot clock (:meth:`Timeline.clock`: a restart, its pairing starts over) and on its stamps
once mapped (:meth:`Timeline.frame_stamp`: a reset of its edges, also when the
reference's restart moved the mapping). It also holds back what cannot be placed yet
(:meth:`Timeline.place` queues up to ``hold_max`` items per vehicle, :meth:`Timeline.release`
gives them back in order once the shift is known) and keeps each vehicle's newest stamp
on the reference timeline (:meth:`Timeline.seen`), which judges staleness elsewhere.

SYSTEM_TIME aligns the timelines; TIMESYNC (:class:`TimesyncProbe`) only measures each
link's round trip, as in ArduPilot/PX4 companion-computer setups (mavros' timesync): the
vehicle answers ``tc1`` = its clock and echoes ``ts1``, the sender's clock, so
``rtt = now - ts1`` on the sender's clock alone.
"""
from __future__ import annotations

from collections import OrderedDict, deque
from dataclasses import dataclass, field

# "the clock went back" and its threshold: one home, shared with every transform listener
from common.tf2_ros.stream import REBOOT_JUMP, clock_went_back  # noqa: F401

HOLD_MAX = 256          # items held per vehicle while its timeline is unknown


@dataclass
class VehicleClock:
    offset: float | None = None          # s: unix time at this vehicle's boot (SYSTEM_TIME)
    newest: float | None = None          # s: newest raw boot-clock reading seen
    newest_wall: float | None = None     # bridge wall time of that reading
    since: float | None = None           # wall time its unknown-timeline period began
    presumed_same: bool = False          # no SYSTEM_TIME within the grace: the reference's world
    offset_changes: int = 0
    restarts: int = 0
    reset_pending: bool = False          # restarted: the next frame stamp resets its edges
    mapped: float | None = None          # s: newest reading on the reference timeline
    mapped_wall: float | None = None     # bridge wall time of that reading
    last_frame: float | None = None      # s: newest frame stamp on the reference timeline
    held: int = 0                        # items held back, in all
    queue: deque = field(default_factory=lambda: deque(maxlen=HOLD_MAX))


class Timeline:
    """Offsets per vehicle and the mapping of their stamps onto the reference's clock."""

    def __init__(self, speedup: float = 1.0, same_world_tol: float = 0.002,
                 grace: float = 1.5, reboot_jump: float = REBOOT_JUMP) -> None:
        self.speedup = speedup
        self.same_world_tol = same_world_tol
        self.grace = grace
        self.reboot_jump = reboot_jump
        self.ref: str | None = None
        self.clocks: dict[str, VehicleClock] = {}

    def _get(self, key: str) -> VehicleClock:
        c = self.clocks.get(key)
        if c is None:
            c = self.clocks[key] = VehicleClock()
        return c

    # ------------------------------------------------------------------ input
    def clock(self, key: str, boot_s: float, wall: float) -> bool:
        """A raw boot-clock reading from `key` at bridge wall time `wall`.

        The first vehicle seen becomes the reference. Returns True when the reading
        shows a restart (clock back by more than reboot_jump): the vehicle's offset is
        forgotten.
        """
        if self.ref is None:
            self.ref = key
        c = self._get(key)
        rebooted = clock_went_back(c.newest, boot_s, self.reboot_jump)
        if rebooted:
            self.forget(key)
            c.restarts += 1
            c.reset_pending = True
        if c.newest is None or boot_s >= c.newest or rebooted:
            c.newest, c.newest_wall = boot_s, wall
        if c.since is None:
            c.since = wall
        return rebooted

    def system_time(self, key: str, time_unix_usec: int, time_boot_ms: int, wall: float) -> float | None:
        """A SYSTEM_TIME from `key`. Returns the previous offset when the offset changed
        by more than same_world_tol (a different or restarted clock), else None."""
        self.clock(key, time_boot_ms / 1000.0, wall)
        c = self._get(key)
        if time_unix_usec <= 0:
            return None        # the vehicle does not know absolute time: no offset
        off = time_unix_usec / 1e6 - time_boot_ms / 1000.0
        old = c.offset
        if old is None or abs(off - old) > self.same_world_tol:
            c.offset = off
            if old is not None:
                c.offset_changes += 1
                return old
        return None

    def forget(self, key: str) -> None:
        """`key` restarted: its offset and presumption no longer hold."""
        c = self._get(key)
        c.offset = None
        for other in (self.clocks.values() if key == self.ref else (c,)):
            other.presumed_same = False
            other.since = None          # the grace starts again at the next reading

    def expire(self, wall: float) -> list[str]:
        """Vehicles whose timeline stayed unknown for `grace` wall seconds: from now on
        presumed to share the reference's world (returned, to be logged)."""
        out = []
        for key, c in self.clocks.items():
            if key != self.ref and not c.presumed_same and c.since is not None \
                    and not self._offsets_known(key) and wall - c.since >= self.grace:
                c.presumed_same = True
                out.append(key)
        return out

    def seen(self, key: str, stamp: float, wall: float) -> None:
        """`key`'s clock read `stamp` on the reference timeline at bridge wall time `wall`."""
        c = self._get(key)
        if c.mapped is None or stamp > c.mapped or clock_went_back(c.mapped, stamp, self.reboot_jump):
            c.mapped, c.mapped_wall = stamp, wall

    def frame_stamp(self, key: str, stamp: float) -> bool:
        """A frame of `key` stamped `stamp` (reference timeline) goes into the tree: True if
        its edges must be reset first (it restarted, or its mapped clock went back)."""
        c = self._get(key)
        reset = c.reset_pending or clock_went_back(c.last_frame, stamp, self.reboot_jump)
        c.reset_pending = False
        if reset or c.last_frame is None or stamp > c.last_frame:
            c.last_frame = stamp
        return reset

    # ------------------------------------------------------------------ holding back
    def place(self, key: str, item) -> float | None:
        """The shift for `item` of `key` if it can go now (known timeline, nothing waiting
        before it), else None: the item is queued (at most hold_max, oldest dropped)."""
        c = self._get(key)
        s = self.shift(key)
        if s is not None and not c.queue:
            return s
        c.held += 1
        c.queue.append(item)
        return None

    def release(self) -> list[tuple[str, list, float]]:
        """(key, items in arrival order, shift) for every vehicle whose held items can go now."""
        out = []
        for key, c in self.clocks.items():
            if c.queue:
                s = self.shift(key)
                if s is not None:
                    items = list(c.queue)
                    c.queue.clear()
                    out.append((key, items, s))
        return out

    def waiting(self, key: str) -> int:
        """Items of `key` held back now."""
        c = self.clocks.get(key)
        return 0 if c is None else len(c.queue)

    def held(self, key: str) -> int:
        c = self.clocks.get(key)
        return 0 if c is None else c.held

    def newest(self, key: str) -> tuple[float | None, float | None]:
        """(stamp on the reference timeline, bridge wall time) of `key`'s newest reading."""
        c = self.clocks.get(key)
        return (None, None) if c is None else (c.mapped, c.mapped_wall)

    def world_clock(self) -> float | None:
        """The newest reading of any vehicle on the reference timeline (s), or None."""
        stamps = [c.mapped for c in self.clocks.values() if c.mapped is not None]
        return max(stamps) if stamps else None

    # ------------------------------------------------------------------ queries
    def _offsets_known(self, key: str) -> bool:
        return self.offset(key) is not None and self.offset(self.ref) is not None

    def offset(self, key: str | None) -> float | None:
        c = self.clocks.get(key) if key is not None else None
        return None if c is None else c.offset

    def clock_disagreement(self, key: str, boot_s: float, wall: float) -> float | None:
        """`key`'s reading minus the reference clock extrapolated to `wall` (s), if known."""
        r = self.clocks.get(self.ref) if self.ref is not None else None
        if r is None or r.newest is None:
            return None
        return boot_s - (r.newest + (wall - r.newest_wall) * self.speedup)

    def shift(self, key: str) -> float | None:
        """What to add to `key`'s boot stamps to put them on the reference timeline,
        or None if its timeline is not known (hold its stamps back)."""
        if self.ref is None or key == self.ref:
            return 0.0
        if self._offsets_known(key):
            d = self.offset(key) - self.offset(self.ref)
            return 0.0 if abs(d) <= self.same_world_tol else d
        c = self.clocks.get(key)
        if c is not None and c.presumed_same:
            return 0.0
        return None

    def to_ref(self, key: str, boot_s: float) -> float | None:
        """`key`'s boot-clock stamp on the reference timeline, or None (unknown timeline)."""
        s = self.shift(key)
        return None if s is None else boot_s + s

    def basis(self, key: str) -> str:
        """How `key`'s stamps are mapped, for logs."""
        if key == self.ref:
            return "reference"
        if self._offsets_known(key):
            return "SYSTEM_TIME offset"
        if self.shift(key) is not None:
            return f"presumed the reference's world (no SYSTEM_TIME within {self.grace:g} s)"
        return "unknown"


class TimesyncProbe:
    """Round trips of one link from TIMESYNC (ts1 = our clock in ns, echoed by the peer)."""

    def __init__(self, keep: int = 16) -> None:
        self.keep = keep
        self._sent: OrderedDict[int, None] = OrderedDict()
        self.rtt: float | None = None        # s, latest
        self.rtt_min: float | None = None
        self.count = 0

    def request(self, now_ns: int) -> int:
        """Remember a request's ts1 (our clock, ns); returns it."""
        ts1 = int(now_ns)
        self._sent[ts1] = None
        while len(self._sent) > self.keep:
            self._sent.popitem(last=False)
        return ts1

    def reply(self, tc1: int, ts1: int, now_ns: int) -> float | None:
        """A TIMESYNC answer: the round trip (s) if it answers one of our requests, else None."""
        if tc1 == 0 or ts1 not in self._sent:
            return None
        del self._sent[ts1]
        rtt = (int(now_ns) - ts1) / 1e9
        if rtt < 0:
            return None
        self.rtt = rtt
        self.rtt_min = rtt if self.rtt_min is None else min(self.rtt_min, rtt)
        self.count += 1
        return rtt
