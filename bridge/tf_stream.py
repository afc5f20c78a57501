"""Transforms as MAVLink: vehicle telemetry -> stamped transforms, and the dialect stream.

* :class:`VehicleFrames` turns one vehicle's LOCAL_POSITION_NED + ATTITUDE_QUATERNION
  into ``world -> <child>`` (full attitude, body FRD) and ``world -> <child>_yaw``
  (yaw-only) TransformStamped, stamped with the vehicle's own clock
  (time_boot_ms / 1000, never the arrival time). Position and attitude are paired by
  time_boot_ms: an exact match first; otherwise the attitude is interpolated (SLERP)
  between the two attitude samples that bracket the position's stamp when they are
  at most ``max_gap`` apart. Duplicated stamps are ignored; out-of-order samples are
  returned (the Buffer inserts them in order); a clock that goes back by more than
  ``reboot_jump`` seconds is a reboot: ``reset`` is reported so the caller clears the
  edge, and pairing starts over. Pairing and reboot detection work on the vehicle's raw
  clock; the router then moves the sample onto the bridge's one timeline
  (bridge.timeline, from SYSTEM_TIME offsets) before it reaches the buffer or the stream.
* :func:`transform_message` / :func:`transform_from_message` encode and decode
  TOWERLINK_TRANSFORM; :class:`TransformListener` fills a Buffer from a stream of
  decoded messages (the tf2 TransformListener of this project, used by tf-echo).
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

from gcs.dialect import towerlink as tl
from gcs.frames import Buffer, Transform, TransformStamped, quaternion_slerp
from gcs.mavstr import mav_str as _s

STATIC_FLAG = tl.TOWERLINK_TRANSFORM_FLAGS_STATIC
FRAME_ID_LEN = 16


def quat_wxyz_to_xyzw(q) -> tuple[float, float, float, float]:
    w, x, y, z = (float(v) for v in q)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not math.isfinite(n) or n < 1e-6:
        raise ValueError(f"bad quaternion {q!r}")
    return (x / n, y / n, z / n, w / n)




@dataclass
class FrameSample:
    """What one paired telemetry sample gives."""
    stamp: float
    full: TransformStamped          # world -> child
    yaw: TransformStamped           # world -> child_yaw
    velocity: tuple[float, float, float]
    reset: bool = False             # the vehicle's clock went back: clear its edges first


@dataclass
class VehicleFrames:
    """Pair one vehicle's position and attitude telemetry into transforms."""

    child: str                      # e.g. "drone"
    parent: str = "world"
    max_gap: float = 0.25           # s: widest attitude bracket to interpolate across
    reboot_jump: float = 1.0        # s: clock going back more than this = reboot
    keep: int = 64                  # samples of each kind kept for pairing
    _pos: dict = field(default_factory=dict)    # ms -> (x,y,z,vx,vy,vz)
    _att: dict = field(default_factory=dict)    # ms -> (x,y,z,w)
    _att_keys: list = field(default_factory=list)
    _done: set = field(default_factory=set)     # ms already published
    newest: float | None = None     # newest stamp seen (s)
    duplicates: int = 0
    reordered: int = 0
    resets: int = 0
    _pending_reset: bool = False

    @property
    def yaw_child(self) -> str:
        return self.child + "_yaw"

    def _clock(self, ms: int) -> None:
        t = ms / 1000.0
        if self.newest is not None and t < self.newest - self.reboot_jump:
            self._pos.clear(); self._att.clear(); self._att_keys.clear(); self._done.clear()
            self.newest = None
            self.resets += 1
            self._pending_reset = True
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
        self._clock(ms)
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
        self._clock(ms)
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
        reset, self._pending_reset = self._pending_reset, False
        return [FrameSample(t, TransformStamped(self.parent, self.child, t, full),
                            TransformStamped(self.parent, self.yaw_child, t, yaw), (vx, vy, vz), reset)]


# ---------------------------------------------------------------------- stream encoding
def _frame_bytes(name: str) -> bytes:
    b = name.encode()
    if len(b) > FRAME_ID_LEN:
        raise ValueError(f"frame id {name!r} is longer than {FRAME_ID_LEN} bytes")
    return b


def transform_message(ts: TransformStamped, static: bool = False):
    """TOWERLINK_TRANSFORM message object for one stamped transform."""
    tr = ts.transform
    return tl.MAVLink_towerlink_transform_message(
        int(round(ts.stamp * 1e6)), _frame_bytes(ts.frame_id), _frame_bytes(ts.child_frame_id),
        [float(v) for v in tr.translation], [float(v) for v in tr.rotation],
        STATIC_FLAG if static else 0)


def transform_from_message(msg) -> tuple[TransformStamped, bool]:
    """(TransformStamped, is_static) from a decoded TOWERLINK_TRANSFORM or TOWERLINK_STATIC_TRANSFORM."""
    stamp = getattr(msg, "time_usec", 0) / 1e6
    tr = Transform(translation=tuple(msg.translation), rotation=tuple(msg.rotation))
    static = msg.get_type() == "TOWERLINK_STATIC_TRANSFORM" or bool(msg.flags & STATIC_FLAG)
    return TransformStamped(_s(msg.frame_id), _s(msg.child_frame_id), float(stamp), tr), static


class TransformListener:
    """Feed decoded MAVLink messages; TOWERLINK_TRANSFORMs go into `buffer`.

    Dynamic edges are keyed by the sender's clock; a dynamic stamp that goes back by
    more than `reboot_jump` seconds resets that edge (a restarted vehicle or bridge).
    """

    def __init__(self, buffer: Buffer | None = None, reboot_jump: float = 1.0) -> None:
        self.buffer = buffer if buffer is not None else Buffer()
        self.reboot_jump = reboot_jump
        self.received = 0
        self.rejected = 0
        self.newest_stamp = 0.0
        self._newest: dict[str, float] = {}

    def feed(self, msg) -> bool:
        if msg is None or msg.get_type() != "TOWERLINK_TRANSFORM":
            return False
        try:
            ts, static = transform_from_message(msg)
        except Exception:
            self.rejected += 1
            return False
        try:
            if static:
                self.buffer.set_transform_static(ts, authority=f"mavlink:{msg.get_srcSystem()}")
            else:
                last = self._newest.get(ts.child_frame_id)
                if last is not None and ts.stamp < last - self.reboot_jump:
                    reset_edge(self.buffer, ts)
                    self._newest[ts.child_frame_id] = ts.stamp
                self._newest[ts.child_frame_id] = max(ts.stamp, self._newest.get(ts.child_frame_id, ts.stamp))
                self.buffer.set_transform(ts, authority=f"mavlink:{msg.get_srcSystem()}")
                self.newest_stamp = max(self.newest_stamp, ts.stamp)
        except Exception:
            self.rejected += 1
            return False
        self.received += 1
        return True


def reset_edge(buffer: Buffer, ts: TransformStamped, authority: str = "reset") -> None:
    """Drop the history of the dynamic edge ts.frame_id -> ts.child_frame_id.

    The Buffer replaces an edge when it switches between static and dynamic
    (documented in gcs.frames.buffer), so writing it once as static and then
    dynamic again empties it without touching any other edge.
    """
    buffer.set_transform_static(ts, authority)
    buffer.set_transform(ts, authority)


def static_transform_message(ts: TransformStamped, target_system: int = 0):
    """TOWERLINK_STATIC_TRANSFORM asking a bridge to add `ts` to its buffer."""
    tr = ts.transform
    return tl.MAVLink_towerlink_static_transform_message(
        target_system, 0, _frame_bytes(ts.frame_id), _frame_bytes(ts.child_frame_id),
        [float(v) for v in tr.translation], [float(v) for v in tr.rotation])


def publish_static(url: str, ts: TransformStamped, timeout: float = 3.0, interval: float = 0.5) -> str:
    """Send `ts` to a bridge's tower port and wait for the bridge's verdict.

    UDP may lose the request, so it is repeated every `interval` wall seconds until
    the bridge answers with its STATUSTEXT ("static tf ... added" / "refused: ...").
    Returns the bridge's text; raises TimeoutError if nothing answered in `timeout`.
    """
    import time

    from gcs.dialect import mavlink_connection

    conn = mavlink_connection(url, source_system=255, source_component=190)
    try:
        deadline = time.monotonic() + timeout
        next_send = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_send:
                conn.mav.send(static_transform_message(ts))
                next_send = time.monotonic() + interval
            msg = conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.1)
            if msg is not None and msg.text.startswith("static tf"):
                return msg.text
        raise TimeoutError(f"no bridge answered at {url} within {timeout:.1f} s")
    finally:
        conn.close()
