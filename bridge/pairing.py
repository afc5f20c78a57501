"""Pairing one vehicle's telemetry into transforms (pure: no sockets, no clocks).

:class:`VehicleFrames` turns LOCAL_POSITION_NED + ATTITUDE_QUATERNION into
``world -> <child>`` (full attitude, body FRD) and ``world -> <child>_yaw`` (yaw-only)
TransformStamped, stamped with the vehicle's own clock (time_boot_ms / 1000, never the
arrival time). Position and attitude are paired by time_boot_ms: an exact match first;
otherwise the attitude is interpolated (SLERP) between the two attitude samples that
bracket the position's stamp when they are at most ``max_gap`` apart. Duplicated stamps
are ignored; out-of-order samples are returned (the Buffer inserts them in order).

Whether the vehicle's clock went back (a reboot) is not decided here: the timeline
(bridge.timeline) owns the vehicle's clock and says so; the owner then calls
:meth:`VehicleFrames.reset` so pairing starts over.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from common.frames import Transform, TransformStamped, quaternion_slerp


def quat_wxyz_to_xyzw(q) -> tuple[float, float, float, float]:
    """MAVLink's (w, x, y, z) as a unit (x, y, z, w); ValueError if not finite or ~0."""
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not math.isfinite(n) or n < 1e-6:
        raise ValueError(f"bad quaternion {q!r}")
    return (x / n, y / n, z / n, w / n)


@dataclass
class FrameSample:
    """What one paired telemetry sample gives (stamps: s, the vehicle's own clock)."""
    stamp: float
    full: TransformStamped          # world -> child
    yaw: TransformStamped           # world -> child_yaw
    velocity: tuple[float, float, float]    # m/s, world NED


@dataclass
class VehicleFrames:
    """Pair one vehicle's position and attitude telemetry into transforms."""

    child: str                      # e.g. "drone"
    parent: str = "world"
    max_gap: float = 0.25           # s: widest attitude bracket to interpolate across
    keep: int = 64                  # samples of each kind kept for pairing
    _pos: dict = field(default_factory=dict)    # ms -> (x,y,z,vx,vy,vz)
    _att: dict = field(default_factory=dict)    # ms -> (x,y,z,w)
    _att_keys: list = field(default_factory=list)
    _done: set = field(default_factory=set)     # ms already published
    newest: float | None = None     # newest stamp seen (s), for the reorder count
    duplicates: int = 0
    reordered: int = 0
    resets: int = 0

    @property
    def yaw_child(self) -> str:
        return self.child + "_yaw"

    def reset(self) -> None:
        """The vehicle's clock started over (the timeline said so): forget every sample."""
        self._pos.clear(); self._att.clear(); self._att_keys.clear(); self._done.clear()
        self.newest = None
        self.resets += 1

    def _seen(self, ms: int) -> None:
        t = ms / 1000.0
        if self.newest is not None and t < self.newest:
            self.reordered += 1
        if self.newest is None or t > self.newest:
            self.newest = t

    def _trim(self) -> None:
        if len(self._pos) > self.keep:
            for k in sorted(self._pos)[: len(self._pos) - self.keep]:
                del self._pos[k]
        if len(self._att_keys) > self.keep:
            for k in self._att_keys[: len(self._att_keys) - self.keep]:
                self._att.pop(k, None)
            del self._att_keys[: len(self._att_keys) - self.keep]
        if len(self._done) > 4 * self.keep:
            cut = sorted(self._done)[-2 * self.keep]
            self._done = {k for k in self._done if k >= cut}

    def on_local_position(self, time_boot_ms, x, y, z, vx, vy, vz) -> list[FrameSample]:
        ms = int(time_boot_ms)
        self._seen(ms)
        if ms in self._done or ms in self._pos:
            self.duplicates += 1
            return []
        vals = tuple(float(v) for v in (x, y, z, vx, vy, vz))
        if not all(math.isfinite(v) for v in vals):
            return []
        self._pos[ms] = vals
        out = self._try_pair(ms)
        self._trim()
        return out

    def on_attitude_quaternion(self, time_boot_ms, q1, q2, q3, q4) -> list[FrameSample]:
        ms = int(time_boot_ms)
        self._seen(ms)
        if ms in self._att:
            self.duplicates += 1
            return []
        try:
            q = quat_wxyz_to_xyzw((q1, q2, q3, q4))
        except ValueError:
            return []
        self._att[ms] = q
        bisect.insort(self._att_keys, ms)
        out = []
        # this attitude may complete its own stamp, or bracket waiting positions
        for pms in sorted(self._pos):
            if pms not in self._done:
                out.extend(self._try_pair(pms))
        self._trim()
        return out

    def _attitude_at(self, ms: int):
        q = self._att.get(ms)
        if q is not None:
            return q
        keys = self._att_keys
        i = bisect.bisect_left(keys, ms)
        if 0 < i < len(keys):
            a, b = keys[i - 1], keys[i]
            if (b - a) / 1000.0 <= self.max_gap:
                return quaternion_slerp(self._att[a], self._att[b], (ms - a) / (b - a))
        return None

    def _try_pair(self, ms: int) -> list[FrameSample]:
        q = self._attitude_at(ms)
        if q is None:
            return []
        x, y, z, vx, vy, vz = self._pos.pop(ms)
        self._done.add(ms)
        t = ms / 1000.0
        full = Transform(translation=(x, y, z), rotation=q)
        yaw = full.yaw_only()
        return [FrameSample(t, TransformStamped(self.parent, self.child, t, full),
                            TransformStamped(self.parent, self.yaw_child, t, yaw), (vx, vy, vz))]
