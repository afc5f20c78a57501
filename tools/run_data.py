"""A run folder's tlogs read back: every vehicle's track and what the bridge recorded.

A run folder (written by `towerlink fly`) holds:

  vehicles.tlog  the fly launcher's own link to the SITL world: every vehicle's
                 telemetry incl. SIM_STATE (truth), PARAM_VALUE, HOME_POSITION
  bridge.tlog    the bridge's transform stream: TOWERLINK_TRANSFORM,
                 TOWERLINK_FOLLOW_STATUS, TOWERLINK_BRIDGE_STATUS
  tower.tlog     the tower's link to the bridge (both directions, tower frame)

`load_run(run_dir)` folds them into a RunData. Positions are world NED, m (world is the
first vehicle's EKF origin, as the bridge's); times are sim seconds from the vehicles' clocks
(time_boot_ms); a message without its own stamp (SIM_STATE) takes the newest time_boot_ms
its system sent before it. Pure data work: no sockets.
"""
from __future__ import annotations

import os
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from common.geo import lla_to_ned, ned_to_lla
from common.mavlink.mavstr import mav_str
from common.mavlink.modes import mode_name
from tools.run_ids import DRONE, ROVER  # noqa: F401 (their users import them here too)
from tools.tlog_stamped import StampedDecoder, decode_frames

os.environ.setdefault("MAVLINK20", "1")

ARDUPILOT, MAV_TYPE_GCS, ARMED_FLAG = 3, 6, 128     # MAV_AUTOPILOT_ARDUPILOTMEGA, MAV_TYPE_GCS, SAFETY_ARMED
ROVER_TYPES = (10, 11)                              # MAV_TYPE_GROUND_ROVER, MAV_TYPE_SURFACE_BOAT


def read_tlog(path: str | os.PathLike, types: Iterable[str] | None = None,
              sysids: Iterable[int] | None = None) -> Iterator[Any]:
    """Every message of a tlog (or those of `types`, by name, and from `sysids`), decoded with
    the towerlink dialect.

    A tlog is an 8-byte big-endian microsecond stamp before each MAVLink frame: the frames are
    cut by their header's length and only the wanted ones decoded (pymavlink's byte-by-byte
    reader cost seconds per run). Each message has ``_timestamp`` (s) and ``_link`` as
    pymavlink's log reader gives them. A file that is not such a sequence throughout (garbage,
    a cut frame) is read by pymavlink's robust reader instead."""
    try:
        from common.mavlink.dialect import towerlink as dialect
    except ImportError:  # pragma: no cover
        from pymavlink.dialects.v20 import ardupilotmega as dialect
    raw = Path(path).read_bytes()
    frames = tlog_frames(raw)
    if frames is None:
        yield from _read_tlog_pymavlink(path, types, sysids)
        return
    yield from decode_frames(dialect.MAVLink(None), raw, frames, wanted_ids(dialect, types), sysids)


def read_stamped(path: str | os.PathLike, fed: Iterable[str], sysids: Iterable[int] | None = None) -> Iterator[Any]:
    """A tlog's messages as a reader of the `fed` messages needs them (tools.tlog_stamped): those
    decoded, the others with a sim time as Stamped. A file that is not whole stamped frames is read
    by pymavlink's robust reader (every message with a time, and the fed ones, decoded)."""
    raw = Path(path).read_bytes()
    frames = tlog_frames(raw)
    decoder = StampedDecoder(fed)
    if frames is None:
        yield from _read_tlog_pymavlink(path, (*fed, *(t.name for t in decoder.timed.values())), sysids)
        return
    yield from decoder.decode(raw, frames, sysids)


def wanted_ids(dialect, types: Iterable[str] | None) -> frozenset[int] | None:
    """The message ids of `types` (names) in `dialect`; None for every message."""
    return None if types is None else frozenset(i for i, c in dialect.mavlink_map.items() if c.msgname in set(types))


def tlog_frames(raw: bytes) -> list[tuple[int, int, int, int]] | None:
    """(stamp us, msgid, start, end) of every frame of a tlog's bytes; None unless the whole
    file is stamps and whole MAVLink 1 or 2 frames."""
    cut = tlog_prefix_frames(raw)
    return cut[0] if cut is not None and cut[1] == len(raw) else None


def tlog_prefix_frames(raw: bytes) -> tuple[list[tuple[int, int, int, int]], int] | None:
    """(frames, end) of the whole frames a tlog's bytes start with (tlog_frames' rows; `end`:
    where the first incomplete one begins, len(raw) if none): a tlog still being written ends
    in a part of a frame. None if the bytes are not stamps and MAVLink 1 or 2 frames."""
    out = []
    i, n = 0, len(raw)
    while i < n:
        j = i + 8
        if j + 8 > n:
            break
        magic = raw[j]
        if magic == 0xFD:
            if j + 10 > n:      # the header itself is cut
                break
            end = j + 12 + raw[j + 1] + (13 if raw[j + 2] & 1 else 0)
            msgid = raw[j + 7] | raw[j + 8] << 8 | raw[j + 9] << 16
        elif magic == 0xFE:
            end = j + 8 + raw[j + 1]
            msgid = raw[j + 5]
        else:
            return None
        if end > n:
            break
        out.append((int.from_bytes(raw[i:j], "big"), msgid, j, end))
        i = end
    return out, i


def _read_tlog_pymavlink(path: str | os.PathLike, types: Iterable[str] | None,
                         sysids: Iterable[int] | None) -> Iterator[Any]:
    try:
        from common.mavlink.dialect import mavlink_connection
    except ImportError:  # pragma: no cover
        from pymavlink.mavutil import mavlink_connection
    wanted = None if types is None else set(types)
    systems = None if sysids is None else set(sysids)
    conn = mavlink_connection(str(path))
    try:
        while True:
            m = conn.recv_msg()
            if m is None:
                return
            if m.get_type() != "BAD_DATA" and (wanted is None or m.get_type() in wanted) \
                    and (systems is None or m.get_srcSystem() in systems):
                yield m
    finally:
        conn.close()


@dataclass
class Track:
    """A time series for one system: t (N,), xyz (N,3) world NED, extra columns by name."""
    t: np.ndarray
    xyz: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.t)

    def at(self, t: float | np.ndarray) -> np.ndarray:
        """Position interpolated linearly at sim time(s) t (clamped to the ends)."""
        return np.stack([np.interp(t, self.t, self.xyz[:, k]) for k in range(3)], axis=-1)

    def window(self, t0: float | None, t1: float | None) -> "Track":
        m = np.ones(len(self.t), bool)
        if t0 is not None:
            m &= self.t >= t0
        if t1 is not None:
            m &= self.t <= t1
        return Track(self.t[m], self.xyz[m], {k: v[m] for k, v in self.extra.items()})


def _track(rows: list[tuple], extra_names: tuple[str, ...] = ()) -> Track:
    if not rows:
        return Track(np.zeros(0), np.zeros((0, 3)), {n: np.zeros(0) for n in extra_names})
    a = np.array(rows, dtype=float)
    order = np.argsort(a[:, 0], kind="stable")
    a = a[order]
    # drop duplicate stamps (keep the last)
    keep = np.append(np.diff(a[:, 0]) > 0, True)
    a = a[keep]
    return Track(a[:, 0], a[:, 1:4], {n: a[:, 4 + i] for i, n in enumerate(extra_names)})


@dataclass
class RunData:
    """What the scorer reads from a run's tlogs."""
    truth: dict[int, Track] = field(default_factory=dict)      # SIM_STATE, world NED
    estimate: dict[int, Track] = field(default_factory=dict)   # LOCAL_POSITION_NED, world
    params: dict[int, dict[str, float]] = field(default_factory=dict)
    follow: dict[str, np.ndarray] = field(default_factory=dict)  # TOWERLINK_FOLLOW_STATUS columns
    transforms: dict[tuple[str, str], list[tuple[float, tuple]]] = field(default_factory=dict)
    statics: dict[tuple[str, str], tuple] = field(default_factory=dict)
    bridge_status: dict[str, dict[str, int]] = field(default_factory=dict)
    follow_frame: int | None = None
    texts: dict[int, list[tuple[float, int, str]]] = field(default_factory=dict)    # STATUSTEXT: (t, severity, text)
    modes: dict[int, list[tuple[float, str, bool]]] = field(default_factory=dict)   # at each change: (t, mode, armed)


#: the towerlink dialect's own messages: what load_run reads of bridge.tlog (the rest repeats vehicles.tlog)
BRIDGE_OWN = ("TOWERLINK_TRANSFORM", "TOWERLINK_STATIC_TRANSFORM", "TOWERLINK_POSITION_TARGET",
              "TOWERLINK_FOLLOW_STATUS", "TOWERLINK_BRIDGE_STATUS", "TOWERLINK_LOCKSTEP")

#: what load_messages folds by name; any other message counts only through its time_boot_ms
FOLDED = ("SIM_STATE", "LOCAL_POSITION_NED", "GPS_GLOBAL_ORIGIN", "HOME_POSITION", "PARAM_VALUE",
          "TOWERLINK_FOLLOW_STATUS", "TOWERLINK_TRANSFORM", "STATUSTEXT", "HEARTBEAT", "TOWERLINK_BRIDGE_STATUS")

FOLLOW_FIELDS = ("t", "ref_x", "ref_y", "full_x", "full_y", "yaw_x", "yaw_y", "goal_x", "goal_y",
                 "rover_x", "rover_y", "height", "tilt", "err_full", "err_yaw", "follow_frame", "state")


def load_messages(msgs: Iterable[Any], data: RunData | None = None) -> RunData:
    """Fold a message stream (one tlog, or several one after the other) into RunData."""
    data = data or RunData()
    last_ms: dict[int, int] = defaultdict(int)
    origin: dict[int, tuple[float, float, float]] = {}
    home: dict[int, tuple[tuple[float, float, float], tuple[float, float, float]]] = {}
    truth_lla: dict[int, list] = defaultdict(list)
    est_rows: dict[int, list] = defaultdict(list)
    follow_rows: list = []
    for m in msgs:
        t = m.get_type()
        src = m.get_srcSystem()
        ms = getattr(m, "time_boot_ms", None)
        if isinstance(ms, int) and t != "SET_POSITION_TARGET_LOCAL_NED" and t != "TOWERLINK_POSITION_TARGET":
            last_ms[src] = max(last_ms[src], ms) if ms + 5000 > last_ms[src] else ms
        if t == "SIM_STATE":
            lat = m.lat_int * 1e-7 if getattr(m, "lat_int", 0) else m.lat
            lon = m.lon_int * 1e-7 if getattr(m, "lon_int", 0) else m.lon
            truth_lla[src].append((last_ms[src] / 1000.0, lat, lon, m.alt, m.roll, m.pitch, m.yaw,
                                   m.vn, m.ve, m.vd))
        elif t == "LOCAL_POSITION_NED":
            est_rows[src].append((m.time_boot_ms / 1000.0, m.x, m.y, m.z, m.vx, m.vy, m.vz))
        elif t == "GPS_GLOBAL_ORIGIN":
            origin[src] = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
        elif t == "HOME_POSITION":
            home[src] = ((m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3), (m.x, m.y, m.z))
        elif t == "PARAM_VALUE":
            data.params.setdefault(src, {})[mav_str(m.param_id)] = float(m.param_value)
        elif t == "TOWERLINK_FOLLOW_STATUS":
            follow_rows.append((m.time_usec * 1e-6, m.ref_x, m.ref_y, m.full_x, m.full_y, m.yaw_x,
                                m.yaw_y, m.goal_x, m.goal_y, m.rover_x, m.rover_y, m.height, m.tilt,
                                m.err_full, m.err_yaw, m.follow_frame, m.state))
        elif t == "TOWERLINK_TRANSFORM":
            key = (mav_str(m.frame_id), mav_str(m.child_frame_id))
            v = tuple(float(x) for x in (*m.translation, *m.rotation))
            if m.flags & 1:
                data.statics[key] = v
            else:
                data.transforms.setdefault(key, []).append((m.time_usec * 1e-6, v))
        elif t == "STATUSTEXT":
            data.texts.setdefault(src, []).append((last_ms[src] / 1000.0, int(m.severity), mav_str(m.text)))
        elif t == "HEARTBEAT" and m.autopilot == ARDUPILOT and m.type != MAV_TYPE_GCS:
            mode = mode_name("rover" if m.type in ROVER_TYPES else "copter", int(m.custom_mode))
            armed = bool(m.base_mode & ARMED_FLAG)
            seen = data.modes.setdefault(src, [])
            if not seen or seen[-1][1:] != (mode, armed):
                seen.append((last_ms[src] / 1000.0, mode, armed))
        elif t == "TOWERLINK_BRIDGE_STATUS":
            data.bridge_status[mav_str(m.link)] = {k: int(getattr(m, k)) for k in
                                              ("rx_packets", "tx_packets", "malformed", "unroutable",
                                               "translated", "deferred")}
    # each vehicle's local NED is centred on its own EKF origin; world is the first vehicle's
    # (the drone's), as the bridge's world is by default
    local0 = {src: _local_origin(origin.get(src), home.get(src)) for src in set(origin) | set(home)}
    local0 = {k: v for k, v in local0.items() if v is not None}
    ref = local0[min(local0)] if local0 else None
    for src, rows in truth_lla.items():
        if ref is None or src not in local0:
            continue
        out = []
        for (tt, lat, lon, alt, r, p, y, vn, ve, vd) in rows:
            n, e, d = lla_to_ned(ref, lat, lon, alt)
            out.append((tt, n, e, d, r, p, y, vn, ve, vd))
        data.truth[src] = _track(out, ("roll", "pitch", "yaw", "vn", "ve", "vd"))
    for src, rows in est_rows.items():
        if ref is not None and src in local0:
            off = lla_to_ned(ref, *local0[src])
            rows = [(tt, x + off[0], y + off[1], z + off[2], *v) for (tt, x, y, z, *v) in rows]
        data.estimate[src] = _track(rows, ("vx", "vy", "vz"))
    if follow_rows:
        a = np.array(follow_rows, dtype=float)
        a = a[np.argsort(a[:, 0], kind="stable")]
        data.follow = {k: a[:, i] for i, k in enumerate(FOLLOW_FIELDS)}
        data.follow_frame = int(a[-1, FOLLOW_FIELDS.index("follow_frame")])
    return data


def _local_origin(origin, home):
    """Where a vehicle's local NED is centred (lat, lon, alt): its GPS_GLOBAL_ORIGIN, else
    HOME_POSITION's lla less its local x, y, z; None if neither was logged."""
    if origin is not None:
        return origin
    if home is not None:
        lla, xyz = home
        return ned_to_lla(lla, (-xyz[0], -xyz[1], -xyz[2]))
    return None


def folded_types() -> tuple[str, ...]:
    """The messages load_messages takes anything from: FOLDED and every message with a
    time_boot_ms (a sender's sim clock). Decoding only these folds the same RunData."""
    try:
        from common.mavlink.dialect import towerlink as dialect
    except ImportError:  # pragma: no cover
        from pymavlink.dialects.v20 import ardupilotmega as dialect
    timed = (c.msgname for c in dialect.mavlink_map.values() if "time_boot_ms" in c.fieldnames)
    return tuple(sorted({*FOLDED, *timed}))


def load_run(run_dir: str | os.PathLike, bridge: Iterable[Any] | None = None) -> RunData:
    """Read every tlog of a run folder (vehicles, bridge, tower) into one RunData. `bridge`:
    bridge.tlog's messages already read by the caller, those of BRIDGE_OWN among them decoded
    (tools.run_mcap.scene_messages(..., also=BRIDGE_OWN)); the others are passed over."""
    run_dir = Path(run_dir)
    data = RunData()
    vehicles = run_dir / "vehicles.tlog"
    if vehicles.exists():
        load_messages(read_stamped(vehicles, FOLDED), data)
        if bridge is not None:
            # the bridge's out link repeats the vehicles' traffic: take its own
            load_messages((m for m in bridge if m.get_type() in BRIDGE_OWN), data)
            return data
    bridge_tlog = run_dir / "bridge.tlog"
    if bridge_tlog.exists():
        # the bridge's out link repeats the vehicles' traffic: take its own
        load_messages(read_tlog(bridge_tlog, BRIDGE_OWN if vehicles.exists() else None), data)
    return data
