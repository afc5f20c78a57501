"""Node: one program's MAVLink connection, shared by its broadcasters, listeners and subscriptions.

rclpy's ``Node`` for this project: a pymavlink connection (any connection string:
``udpout:127.0.0.1:14620`` to a bridge's node link, ``udpin:...``, ``tcp:...``), one
background thread that reads it and hands each message to the callbacks subscribed to
its type (tf2_ros's listener thread is this thread), and a lock around sending, so any
thread may send. It says HEARTBEAT once a second (MAV_TYPE_ONBOARD_CONTROLLER): a
``udpin`` bridge link only answers peers that wrote to it, so a node that only
listens still gets the stream.

    node = Node("world_to_drone", "udpout:127.0.0.1:14620")
    node.subscribe("LOCAL_POSITION_NED", on_position, sysid=1)
    rate = node.rate(10)                 # sleep to 10 Hz wall
    while node.ok():
        ...
        rate.sleep()
    node.close()

Identity on the wire: ``source_system`` (default 255, a GCS-side system, the one a
bridge trusts by default: --trust-sysid) and ``source_component`` (default: a
MAV_COMP_ID_USER1..75 number derived from the node's name: names usually get different
numbers, but two of 75 can meet, so give source_component= when two nodes must differ).
The bridge's frame authority is per (sysid, compid): see bridge.node_frames.
"""
from __future__ import annotations

import os
import sys
import threading
import time
import zlib
from collections.abc import Callable

DEFAULT_URL = "udpout:127.0.0.1:14620"
NODE_SYSID = 255
MAV_COMP_ID_USER1 = 25
HEARTBEAT_PERIOD = 1.0      # wall s


def component_for(name: str) -> int:
    """A MAV_COMP_ID_USER1..USER75 component id for a node name (stable across runs)."""
    return MAV_COMP_ID_USER1 + zlib.crc32(name.encode()) % 75


class Rate:
    """rospy.Rate: sleep() keeps a loop at `hz` wall (no catch-up burst after a stall)."""

    def __init__(self, hz: float, node: "Node | None" = None) -> None:
        if not hz > 0:
            raise ValueError(f"rate must be > 0 Hz, got {hz!r}")
        self.period = 1.0 / hz
        self.node = node
        self._next = time.monotonic() + self.period

    def sleep(self) -> None:
        delay = self._next - time.monotonic()
        if delay > 0:
            if self.node is not None:
                self.node._closed.wait(delay)      # wakes at once when the node closes
            else:
                time.sleep(delay)
        now = time.monotonic()
        self._next = max(self._next + self.period, now)


class Node:
    def __init__(self, name: str, url: str = DEFAULT_URL, *, source_system: int = NODE_SYSID,
                 source_component: int | None = None, heartbeat: bool = True,
                 log: Callable[[str], None] | None = None) -> None:
        from common.mavlink.dialect import mavlink_connection
        from common.mavlink.dialect import towerlink as tl

        os.environ.setdefault("MAVLINK20", "1")
        self.name = name
        self.url = url
        self.tl = tl
        self.source_system = source_system
        self.source_component = component_for(name) if source_component is None else source_component
        self.conn = mavlink_connection(url, source_system=source_system,
                                       source_component=self.source_component)
        self._log = log
        self._send_lock = threading.Lock()
        self._subs: dict[str, list[tuple[Callable, int | None]]] = {}
        self._periodic: list[list] = []          # [period, next_due, fn]
        self._closed = threading.Event()
        self.received = 0
        self.callback_errors = 0
        if heartbeat:
            self.every(HEARTBEAT_PERIOD, self._heartbeat)
        self._thread = threading.Thread(target=self._spin, name=f"node-{name}", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ API
    def subscribe(self, msg_type: str, callback: Callable, sysid: int | None = None) -> None:
        """Call `callback(msg)` (in the node's thread) for each `msg_type` message (from `sysid`)."""
        self._subs.setdefault(msg_type, []).append((callback, sysid))

    def every(self, period: float, fn: Callable[[], None]) -> None:
        """Call `fn()` in the node's thread every `period` wall seconds (first call at once)."""
        self._periodic.append([period, 0.0, fn])

    def send(self, msg) -> None:
        """Send a pymavlink message object as this node (thread-safe)."""
        with self._send_lock:
            self.conn.mav.send(msg)

    def rate(self, hz: float) -> Rate:
        return Rate(hz, self)

    def ok(self) -> bool:
        """False once close() was called (rospy.is_shutdown's opposite)."""
        return not self._closed.is_set()

    def spin(self) -> None:
        """Block until the node is closed (callbacks run in the node's thread)."""
        self._closed.wait()

    def log(self, text: str) -> None:
        if self._log is not None:
            self._log(text)
        else:
            print(f"[{self.name}] {text}", file=sys.stderr, flush=True)

    def close(self) -> None:
        self._closed.set()
        if self._thread is not threading.current_thread():
            self._thread.join(2.0)
        try:
            self.conn.close()
        except OSError:
            pass

    def __enter__(self) -> "Node":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ the thread
    def _heartbeat(self) -> None:
        tl = self.tl
        self.send(tl.MAVLink_heartbeat_message(tl.MAV_TYPE_ONBOARD_CONTROLLER, tl.MAV_AUTOPILOT_INVALID,
                                               0, 0, tl.MAV_STATE_ACTIVE, 3))

    def _run_periodic(self) -> None:
        now = time.monotonic()
        for entry in self._periodic:
            if now >= entry[1]:
                entry[1] = now + entry[0]
                self._call(entry[2])

    def _call(self, fn: Callable, *args) -> None:
        try:
            fn(*args)
        except Exception as exc:  # noqa: BLE001 - one bad callback must not stop the node
            self.callback_errors += 1
            if self.callback_errors <= 5:
                self.log(f"callback {getattr(fn, '__name__', fn)!s} failed: {exc!r}")

    def _spin(self) -> None:
        while not self._closed.is_set():
            self._run_periodic()
            try:
                msg = self.conn.recv_match(blocking=True, timeout=0.05)
            except (OSError, ValueError):
                if self._closed.is_set():
                    return
                msg = None
                self._closed.wait(0.05)
            if msg is None:
                continue
            mtype = msg.get_type()
            if mtype == "BAD_DATA":
                continue
            self.received += 1
            for cb, sysid in [*self._subs.get(mtype, ()), *self._subs.get("*", ())]:
                if sysid is None or msg.get_srcSystem() == sysid:
                    self._call(cb, msg)
