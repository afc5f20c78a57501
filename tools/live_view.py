"""Serve a running system to Foxglove, live (`towerlink fly --view`, `towerlink view`).

Foxglove's WebSocket protocol (the `foxglove-sdk` package, an optional extra:
`pip install towerlink[view]`) on a local port: open the Foxglove app, "Open connection",
"Foxglove WebSocket", ws://127.0.0.1:PORT, and import docs/foxglove_layout.json for a
ready view. The channels are those of tools/scene_feed.py, on the sim clock (the server
advertises the Time capability and broadcasts sim time, so the app's clock is the world's).

Cost: the feed runs in the process that hears the messages (the `fly` launcher's monitor,
or `towerlink view`), never in the world. With no client connected nothing is encoded or
sent (each channel is checked for subscribers first).
"""
from __future__ import annotations

import argparse
import json
import sys
import threading

from tools.scene_feed import TOPICS, SceneFeed, schema_of

DEFAULT_VIEW_PORT = 8765


class LiveView:
    """A Foxglove WebSocket server fed with MAVLink messages (thread-safe enough for one feeder)."""

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_VIEW_PORT, name: str = "towerlink") -> None:
        try:
            import foxglove
        except ImportError as exc:   # the extra is not installed: say how to get it
            raise RuntimeError("the live view needs the foxglove-sdk package: "
                               "pip install 'towerlink[view]'") from exc
        self._fg = foxglove
        self.context = foxglove.Context()
        self.server = foxglove.start_server(name=name, host=host, port=port, context=self.context,
                                            capabilities=[foxglove.Capability.Time])
        self.channels = {}
        for topic in TOPICS:
            sname, schema = schema_of(topic)
            self.channels[topic] = foxglove.Channel(
                topic, schema=foxglove.Schema(name=sname, encoding="jsonschema",
                                              data=json.dumps(schema).encode()),
                message_encoding="json", context=self.context)
        self.feed = SceneFeed()
        self._last_time_ns = -1
        self._lock = threading.Lock()     # the monitor and the tower reader feed from two threads

    @property
    def port(self) -> int:
        return self.server.port

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}"

    def on_message(self, m) -> None:
        """Feed one decoded MAVLink message (in arrival order)."""
        with self._lock:
            self._log(self.feed.feed(m))

    def goal(self, sim_s: float, p: tuple[float, float, float]) -> None:
        """A tower goal as the tower reported sending it (tower frame, NED, m; sim s)."""
        with self._lock:
            self._log(self.feed.add_goal(int(sim_s * 1e9), p))

    def _log(self, records) -> None:
        for r in records:
            ch = self.channels[r.topic]
            if ch.has_sinks():
                ch.log(r.body, log_time=r.sim_ns)
        if self.feed.sim_ns > self._last_time_ns:
            self._last_time_ns = self.feed.sim_ns
            self.server.broadcast_time(self.feed.sim_ns)

    def stop(self) -> None:
        self.server.stop()


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--connect", default="udpin:127.0.0.1:14610",
                   help="where the bridge's stream arrives (start the bridge with --out udpout:...; "
                        "default %(default)s)")
    p.add_argument("--port", type=int, default=DEFAULT_VIEW_PORT,
                   help="Foxglove WebSocket port (default %(default)s; 0 picks a free one)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default %(default)s)")


def run(args: argparse.Namespace) -> int:
    from common.mavlink.dialect import mavlink_connection
    try:
        view = LiveView(args.host, args.port)
    except (RuntimeError, OSError) as exc:
        print(f"towerlink view: {exc}", file=sys.stderr)
        return 2
    print(f"towerlink view: Foxglove WebSocket on {view.url} (open it in the Foxglove app); "
          f"listening on {args.connect}", flush=True)
    conn = mavlink_connection(args.connect)
    try:
        while True:
            m = conn.recv_match(blocking=True, timeout=1.0)
            if m is not None and m.get_type() != "BAD_DATA":
                view.on_message(m)
    except KeyboardInterrupt:
        return 0
    finally:
        conn.close()
        view.stop()
