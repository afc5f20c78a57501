"""A run as MCAP (`run.mcap`), the log format Foxglove and ROS 2 share; and reading it back.

`write_run_mcap(run_dir)` turns the run's tlogs into run.mcap with the channels of
tools/scene_feed.py (the same ones the live view serves), every message's log time being
its sim time in nanoseconds, written in sim-time order. The file is written beside the
tlogs atomically (a temporary file renamed into place), so a crash never leaves half a file.

`buffer_from_mcap(path)` fills a frame Buffer from /tf and /tf_static, so `tf-echo` and
`view-frames` read an MCAP as they read a tlog.
"""
from __future__ import annotations

import heapq
import json
import math
import os
import re
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from common.mavlink.ids import TOWER_SYSID
from tools.scene_feed import FED_TYPES, TOPICS, Record, SceneFeed, TrackPoints, records_of, schema_of

RUN_MCAP = "run.mcap"


def _tlog_messages(run_dir: Path, bridge: Iterable | None = None) -> Iterator:
    """bridge.tlog (frames, follow, vehicles; `bridge`: its messages already read) and the
    tower's own sends from tower.tlog, merged in arrival order (the tlogs' wall stamps); decoded
    as far as SceneFeed reads them (scene_messages)."""
    streams = []
    if bridge is not None:
        streams.append(iter(bridge))
    elif (run_dir / "bridge.tlog").exists():
        streams.append(scene_messages(run_dir / "bridge.tlog"))
    if (run_dir / "tower.tlog").exists():
        streams.append(scene_messages(run_dir / "tower.tlog", sysids=(TOWER_SYSID,)))
    return heapq.merge(*streams, key=lambda m: getattr(m, "_timestamp", 0.0))


def scene_messages(path: str | os.PathLike, sysids: Iterable[int] | None = None,
                   also: Iterable[str] = ()) -> Iterator:
    """A finished tlog's messages as SceneFeed needs them (tools.tlog_stamped; those named in
    `also` decoded too)."""
    from tools.run_data import read_stamped
    return read_stamped(path, (*FED_TYPES, *also), sysids)


def write_mcap(records: Iterable[Record], path: str | os.PathLike) -> int:
    """Write records to an MCAP file atomically, sorted by sim time; returns the count."""
    return write_encoded([encode(r) for r in records], path)


def encode(r: Record) -> tuple[int, str, bytes]:
    """(sim ns, topic, JSON body): a record as write_encoded takes it."""
    return r.sim_ns, r.topic, dumps(r.body).encode()


_HELD = re.compile(r'"\\u0000(\d+)"')      # a placeholder as json.dumps writes it


def dumps(body: dict) -> str:
    """json.dumps(body), byte for byte, with the text of each track's points (scene_feed.TrackPoints
    in an entity's lines) taken as the feed made it rather than encoded again."""
    held: list[str] = []

    def line(ln: dict) -> dict:
        pts = ln.get("points")
        if not isinstance(pts, TrackPoints):
            return ln
        held.append(pts.json)
        return {**ln, "points": f"\0{len(held) - 1}"}     # a key keeps its place when set again

    ents = body.get("entities")
    if isinstance(ents, list):
        body = {**body, "entities": [{**e, "lines": [line(ln) for ln in e["lines"]]} if e.get("lines") else e
                                     for e in ents]}
    text = json.dumps(body)
    return _HELD.sub(lambda m: held[int(m.group(1))], text) if held else text


def write_encoded(recs: list[tuple[int, str, bytes]], path: str | os.PathLike) -> int:
    """Write encoded records (`encode`'s, in arrival order) to an MCAP file atomically, sorted
    by sim time; returns the count."""
    from mcap.writer import CompressionType, Writer

    recs = sorted(recs, key=lambda r: r[0])     # stable: arrival order within a stamp
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            w = Writer(f, compression=CompressionType.ZSTD if _has_zstd() else CompressionType.NONE)
            w.start(profile="", library="towerlink")
            channels: dict[str, int] = {}
            schemas: dict[str, int] = {}
            for topic in TOPICS:
                name, schema = schema_of(topic)
                if name not in schemas:
                    schemas[name] = w.register_schema(name=name, encoding="jsonschema",
                                                      data=json.dumps(schema).encode())
                channels[topic] = w.register_channel(topic=topic, message_encoding="json",
                                                     schema_id=schemas[name])
            for seq, (ns, topic, data) in enumerate(recs):
                w.add_message(channel_id=channels[topic], log_time=ns, publish_time=ns,
                              data=data, sequence=seq & 0xFFFFFFFF)
            w.finish()
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return len(recs)


def _has_zstd() -> bool:
    try:
        import zstandard  # noqa: F401
        return True
    except ImportError:
        return False


def write_run_mcap(run_dir: str | os.PathLike, bridge: Iterable | None = None) -> Path:
    """run_dir/run.mcap from the run's tlogs (`bridge`: bridge.tlog's messages, when the caller
    has read them already); returns its path."""
    run_dir = Path(run_dir)
    out = run_dir / RUN_MCAP
    write_mcap(records_of(_tlog_messages(run_dir, bridge), SceneFeed()), out)
    return out


def read_records(path: str | os.PathLike, topics: Iterable[str] | None = None) -> Iterator[tuple[str, int, dict]]:
    """(topic, log time ns, decoded JSON body) of every message, in file order."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(topics=list(topics) if topics else None):
            yield channel.topic, message.log_time, json.loads(message.data)


def buffer_from_mcap(path: str | os.PathLike, cache_time: float = 1e9):
    """(Buffer, stamps, latest sim time): every transform of /tf and /tf_static in a Buffer.

    stamps maps each dynamic child frame to the set of its sample times (s), as tf-echo's
    tlog reader does, so `tf-echo --mcap` can print at every stamp of a chain.
    """
    from common.frames import Buffer, Transform, TransformStamped

    buf = Buffer(cache_time=cache_time)
    stamps: dict[str, set[float]] = {}
    latest = 0.0
    for topic, ns, body in read_records(path, ("/tf", "/tf_static")):
        for ft in body.get("transforms", []):
            tr, q = ft["translation"], ft["rotation"]
            vals = (tr["x"], tr["y"], tr["z"], q["x"], q["y"], q["z"], q["w"])
            if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in vals):
                continue
            t = ft["timestamp"]["sec"] + ft["timestamp"]["nsec"] * 1e-9
            ts = TransformStamped(ft["parent_frame_id"], ft["child_frame_id"],
                                  0.0 if topic == "/tf_static" else t,
                                  Transform(vals[:3], vals[3:]))
            if topic == "/tf_static":
                buf.set_transform_static(ts, "mcap")
            else:
                buf.set_transform(ts, "mcap")
                stamps.setdefault(ft["child_frame_id"], set()).add(t)
                latest = max(latest, t)
    return buf, stamps, latest
