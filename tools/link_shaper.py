"""One direction of a faulty radio link: which frames arrive, when, and how often (pure: no sockets, no clocks).

:class:`LinkDirection` takes frames (tools.link_frames.Unit) with the time they were sent and
hands back the frames to deliver, each when its time has come, under a
common.link_settings.LinkSettings: lost with probability `loss`; serialised at `bandwidth`
bytes/s behind the frames before it (a frame that would wait more than QUEUE_LIMIT s is dropped:
`overflow`); then delayed by `latency`, plus up to `jitter`, plus REORDER_HOLD for the
`reorder` fraction; the `duplicate` fraction delivered twice. It never invents a frame: what
comes out is what went in, at most twice.

Two clocks:

* wall (``lockstep=False``): ``receive(units, now)`` at arrival, ``release(now)`` whenever
  the caller likes (``next_due()`` says when something is due);
* lockstep (``lockstep=True``): the link's frames belong to the sim clock that the world's
  TOWERLINK_LOCKSTEP markers carry (the TICK going down, the tower's ACK going up).
  ``receive`` only collects; ``marker(t)`` offers what came since the previous marker as sent
  over (previous, t], sorted by sender so the order is the senders' own and not the
  machine's, and returns what is due by t, to go on before the marker. Before the first marker
  frames pass untouched (the world has not started).

Random draws are counter-based: a frame's numbers are a hash of the seed, the direction, its
stream (sysid, compid, msgid), the epoch (the marker's sim time in lockstep, 0 on the wall
clock) and its index in that stream within the epoch. So in lockstep the same seed gives the
same fate to the same frame whatever else the machine interleaved, at any speed and load;
on the wall clock the same frames in the same order give the same fates (a replayable run).
"""
from __future__ import annotations

import heapq
from collections.abc import Iterable

from common.link_settings import QUEUE_LIMIT, REORDER_HOLD, LinkSettings
from tools.link_frames import Unit

M64 = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15
_SALT = {"up": 0x7570, "down": 0x646F776E}
_TO_UNIT32 = 1.0 / 2 ** 32
EPS = 1e-9                  # s: a frame due at t + latency is due at the marker of that time (float sums)


def _mix(z: int) -> int:
    """splitmix64's finaliser: a 64-bit hash of z."""
    z = (z + _GOLDEN) & M64
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def draws(salt: int, key: tuple[int, int, int], epoch: int, k: int) -> tuple[float, float, float, float]:
    """Four uniforms in [0, 1) for frame k of stream `key` in `epoch` (salt: seed and direction)."""
    sysid, compid, msgid = key
    return _four(_mix(salt ^ ((sysid & 0xFFFF) << 40 | (compid & 0xFFFF) << 24 | (msgid & 0xFFFFFF))),
                 _mix(epoch & M64), k)


def _four(stream: int, epoch: int, k: int) -> tuple[float, float, float, float]:
    """The four uniforms from a stream's hash, an epoch's hash and the index (32 bits each)."""
    a = _mix(stream ^ epoch ^ (k * _GOLDEN & M64))
    b = _mix(a ^ 0x5851F42D4C957F2D)
    return ((a >> 32) * _TO_UNIT32, (a & 0xFFFFFFFF) * _TO_UNIT32, (b >> 32) * _TO_UNIT32,
            (b & 0xFFFFFFFF) * _TO_UNIT32)


def salt_of(seed: int, direction: str) -> int:
    return _mix(_mix(seed & M64) ^ _SALT[direction])


class LinkDirection:
    """One direction of a link (see the module doc). `counts`: frames passed (not lost), dropped
    (lost), overflow (the capped link's queue was full), duplicated (sent twice)."""

    def __init__(self, name: str, seed: int, settings: LinkSettings | None = None, lockstep: bool = False) -> None:
        if name not in _SALT:
            raise ValueError(f"direction {name!r}: up or down")
        self.name = name
        self.lockstep = lockstep
        self.settings = settings or LinkSettings()
        self._salt = salt_of(seed, name)
        self._heap: list[tuple[float, int, Unit]] = []
        self._order = 0                     # ties in due time go in the order offered
        self._busy = float("-inf")          # when the capped link is free again
        self._epoch: int | None = None
        self._seen: dict[tuple[int, int, int], int] = {}     # frames of each stream in this epoch
        self._epoch_hash = 0
        self._streams: dict[tuple[int, int, int], int] = {}  # each stream's hash (draws)
        self._batch: list[Unit] = []        # lockstep: since the last marker
        self.clock: float | None = None     # lockstep: the last marker's sim time
        self.counts = {"passed": 0, "dropped": 0, "overflow": 0, "duplicated": 0}

    # -- the caller's side

    def set_settings(self, settings: LinkSettings) -> None:
        """New settings, for the frames offered from now on (held ones keep their times)."""
        self.settings = settings

    @property
    def holding(self) -> int:
        """Frames held (collected or delayed)."""
        return len(self._heap) + len(self._batch)

    def receive(self, units: Iterable[Unit], now: float = 0.0) -> list[Unit]:
        """Frames from the sender at `now` (wall s; ignored in lockstep). Returns what goes on now."""
        units = list(units)
        if not self.settings.active and not self._batch:
            self.counts["passed"] += len(units)         # a perfect link: at once (frames still in flight may
            return units                                # arrive after: they were sent on a slower link)
            return units
        if self.lockstep:
            if self.clock is None:                      # before the world's first frame
                self.counts["passed"] += len(units)
                return units
            self._batch.extend(units)
            return []
        self._offer(units, now, now, 0)
        return self.release(now)

    def marker(self, t: float) -> list[Unit]:
        """Lockstep: the marker of sim time t came (it goes on after what this returns): the frames
        since the previous marker are offered as sent over (previous, t]; returned: all due by t."""
        if self.clock is not None and t <= self.clock:
            return []               # a marker sent again (a lost one): nothing new has come since
        t0 = self.clock if self.clock is not None else t
        self.clock = t
        batch, self._batch = self._batch, []
        if batch:
            batch.sort(key=lambda u: (u.key[0], u.key[1]))      # each sender's own order, senders by id
            self._offer(batch, t0, t, int(round(t * 1e6)))
        return self.release(t)

    def release(self, now: float) -> list[Unit]:
        """Every held frame due by `now`, in due order (ties: the order offered)."""
        out = []
        heap = self._heap
        while heap and heap[0][0] <= now + EPS:
            out.append(heapq.heappop(heap)[2])
        return out

    def next_due(self) -> float | None:
        """When the next held frame is due (None: none held)."""
        return self._heap[0][0] if self._heap else None

    # -- the model

    def _offer(self, units: list[Unit], t0: float, t1: float, epoch: int) -> None:
        """Frames sent over [t0, t1] (one instant on the wall clock): their fates."""
        s = self.settings
        if epoch != self._epoch:
            self._epoch, self._seen, self._epoch_hash = epoch, {}, _mix(epoch & M64)
        seen, counts, streams, eh = self._seen, self.counts, self._streams, self._epoch_hash
        for u in units:
            key = u.key
            k = seen.get(key, 0)
            seen[key] = k + 1
            sh = streams.get(key)
            if sh is None:
                sysid, compid, msgid = key
                sh = streams[key] = _mix(self._salt ^ ((sysid & 0xFFFF) << 40 | (compid & 0xFFFF) << 24 |
                                                       (msgid & 0xFFFFFF)))
            lost, twice, jit, held = _four(sh, eh, k)
            copies = 2 if twice < s.duplicate else 1
            readies = [t1] * copies
            if s.bandwidth > 0:         # each copy takes its turn on the link
                start = max(self._busy, t0)
                if start - t0 > QUEUE_LIMIT:
                    counts["overflow"] += 1
                    continue
                for c in range(copies):
                    start += len(u.data) / s.bandwidth
                    readies[c] = max(start, t1)
                self._busy = start
            if lost < s.loss:
                counts["dropped"] += 1
                continue
            counts["passed"] += 1
            delay = s.latency + jit * s.jitter + (REORDER_HOLD if held < s.reorder else 0.0)
            for ready in readies:
                heapq.heappush(self._heap, (ready + delay, self._order, u))
                self._order += 1
            if copies == 2:
                counts["duplicated"] += 1
