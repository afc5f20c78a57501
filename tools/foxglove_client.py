"""A small Foxglove WebSocket client for tests and bench_view (the protocol is public: foxglove/ws-protocol).

Connects with the SDK's subprotocol, reads the server's `advertise`, subscribes to the
topics asked for, and collects (topic, log_time_ns, decoded JSON) and the server's time
broadcasts on a background thread until stopped.
"""
from __future__ import annotations

import json
import struct
import threading
import time

SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")
OP_MESSAGE_DATA, OP_TIME = 1, 2


class FoxgloveClient(threading.Thread):
    def __init__(self, url: str, topics: tuple[str, ...]) -> None:
        super().__init__(daemon=True, name="foxglove-client")
        from websockets.sync.client import connect
        self._conn = connect(url, subprotocols=list(SUBPROTOCOLS), open_timeout=10)
        self.ws = self._conn.__enter__()
        self.topics = set(topics)
        self.channels: dict[int, dict] = {}      # channel id -> advertised channel
        self.subs: dict[int, str] = {}           # subscription id -> topic
        self.messages: list[tuple[str, int, dict]] = []
        self.times: list[int] = []
        self.lock = threading.Lock()
        self._halt = threading.Event()
        self.start()

    def run(self) -> None:
        from websockets.exceptions import ConnectionClosed
        while not self._halt.is_set():
            try:
                frame = self.ws.recv(timeout=0.2)
            except TimeoutError:
                continue
            except ConnectionClosed:
                return
            if isinstance(frame, str):
                self._text(json.loads(frame))
            elif frame and frame[0] == OP_MESSAGE_DATA:
                sub, log_time = struct.unpack_from("<IQ", frame, 1)
                with self.lock:
                    self.messages.append((self.subs.get(sub, "?"), log_time, json.loads(frame[13:])))
            elif frame and frame[0] == OP_TIME:
                with self.lock:
                    self.times.append(struct.unpack_from("<Q", frame, 1)[0])

    def _text(self, msg: dict) -> None:
        if msg.get("op") != "advertise":
            return
        new = []
        for ch in msg["channels"]:
            self.channels[ch["id"]] = ch
            if ch["topic"] in self.topics:
                sid = len(self.subs) + 1
                self.subs[sid] = ch["topic"]
                new.append({"id": sid, "channelId": ch["id"]})
        if new:
            self.ws.send(json.dumps({"op": "subscribe", "subscriptions": new}))

    def of(self, topic: str) -> list[tuple[int, dict]]:
        with self.lock:
            return [(t, body) for tp, t, body in self.messages if tp == topic]

    def wait_for(self, pred, timeout: float, what: str) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if pred():
                return
            time.sleep(0.02)      # polling a condition with a deadline, not settling
        raise AssertionError(f"timed out waiting for {what}")

    def stop(self) -> None:
        self._halt.set()
        self.join(2.0)
        try:
            self._conn.__exit__(None, None, None)
        except Exception:  # noqa: BLE001
            pass
