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

Lockstep (``lockstep=True``, or the environment variable TOWERLINK_NODE_LOCKSTEP=1 that
`towerlink fly --nodes` and `towerlink lab check` set): the node takes part in the world's
lockstep through the bridge's node link (``towerlink bridge --nodes URL --lockstep``). It
JOINs the bridge once the program is ready (its first ``ok()``, ``spin()`` or ``Rate.sleep()``:
its subscriptions are made, so it misses nothing the run sends); each TOWERLINK_LOCKSTEP TICK the bridge sends is the node's clock
(:meth:`Node.now`, sim seconds); ``Rate.sleep()`` waits for sim time; and the node ACKs a TICK
only after its callbacks have handled everything that came before it and its loop has run for
that sim time (common.tf2_ros.sim_clock). What the node sends between TICKs (a callback's
reaction to data that came while the world ran on) is held and goes out at the next TICK,
before its ACK. The bridge answers the world only when every node has ACKed, so everything a
node sends takes effect at a TICK the data fixes: a run's figures are the same at any speed.
Closing the node sends LEAVE.
"""
from __future__ import annotations

import atexit
import os
import sys
import threading
import time
import zlib
from collections.abc import Callable

from common.mavlink import lockstep as ls

from .sim_clock import LockstepClock

DEFAULT_URL = "udpout:127.0.0.1:14620"
NODE_SYSID = 255
MAV_COMP_ID_USER1 = 25
HEARTBEAT_PERIOD = 1.0      # wall s
LOCKSTEP_ENV = "TOWERLINK_NODE_LOCKSTEP"    # "1": nodes of this process join the lockstep
JOIN_PERIOD = 0.5           # wall s between JOINs while no TICK comes
REJOIN_AFTER = 1.0          # wall s without a TICK before JOINing again (a restarted bridge)


def node_args(doc: str | None = None, follow_frame: bool = False):
    """A node program's options: --connect URL (the bridge's node link, default DEFAULT_URL) and
    with `follow_frame` --follow-frame drone|drone_yaw. Options meant for other nodes (a launcher
    gives every node the same ones) are left alone."""
    import argparse
    ap = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--connect", default=DEFAULT_URL, help="the bridge's node link (default %(default)s)")
    if follow_frame:
        ap.add_argument("--follow-frame", choices=("drone", "drone_yaw"), default="drone_yaw",
                        help="the drone frame the goal is written in (default %(default)s)")
    return ap.parse_known_args()[0]


def lockstep_from_env() -> bool:
    """Does the environment (a launcher in lockstep) ask nodes to join the lockstep?"""
    return os.environ.get(LOCKSTEP_ENV, "") not in ("", "0")


def component_for(name: str) -> int:
    """A MAV_COMP_ID_USER1..USER75 component id for a node name (stable across runs)."""
    return MAV_COMP_ID_USER1 + zlib.crc32(name.encode()) % 75


def _where(exc: BaseException) -> str:
    """' at FILE line N': the deepest frame of the exception's traceback (where the callback broke)."""
    import traceback
    tb = traceback.extract_tb(exc.__traceback__)
    return f" at {os.path.basename(tb[-1].filename)} line {tb[-1].lineno}" if tb else ""


class Rate:
    """rospy.Rate: sleep() keeps a loop at `hz` (no catch-up burst after a stall): wall time, or
    with a lockstep node the node's sim time."""

    def __init__(self, hz: float, node: "Node | None" = None) -> None:
        if not hz > 0:
            raise ValueError(f"rate must be > 0 Hz, got {hz!r}")
        self.period = 1.0 / hz
        self.node = node
        self.sim = node.clock if node is not None and node.clock is not None else None
        self._next = (self.sim.now() if self.sim else time.monotonic()) + self.period

    def sleep(self) -> None:
        if self.sim is not None:
            self.node.ready()
            self.sim.sleep_until(self._next)
            self._next = max(self._next + self.period, self.sim.now() + 1e-9)
            return
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
                 log: Callable[[str], None] | None = None, lockstep: bool | None = None) -> None:
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
        self.lockstep = lockstep_from_env() if lockstep is None else bool(lockstep)
        self.clock = LockstepClock() if self.lockstep else None
        self._last_tick_wall = -1e9
        self._ready = False
        self._in_tick = False               # the node's thread is handling a TICK (sends go out)
        self._held: list = []               # sent between TICKs: out at the next one
        if heartbeat:
            self.every(HEARTBEAT_PERIOD, self._heartbeat)
        if self.lockstep:
            self.every(JOIN_PERIOD, self._join)
            atexit.register(self.close)         # a node that ends without close() still says LEAVE
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
        """Send a pymavlink message object as this node (thread-safe). With lockstep, once the
        TICKs come, what is sent between two TICKs waits for the next one."""
        with self._send_lock:
            if self.clock is not None and self.clock.ticks and not self._in_tick:
                self._held.append(msg)
                return
            self.conn.mav.send(msg)

    def _send_now(self, msg) -> None:
        """Send at once: the node's own HEARTBEAT and TOWERLINK_LOCKSTEP."""
        with self._send_lock:
            self.conn.mav.send(msg)

    def rate(self, hz: float) -> Rate:
        return Rate(hz, self)

    def now(self) -> float:
        """rospy.Time.now(): with lockstep the sim time of the newest TICK (s), else the wall
        clock (time.monotonic, s). Stamp transforms with the vehicle's time, not with this."""
        return self.clock.now() if self.clock is not None else time.monotonic()

    def ok(self) -> bool:
        """False once close() was called (rospy.is_shutdown's opposite)."""
        self._ready = True
        return not self._closed.is_set()

    def spin(self) -> None:
        """Block until the node is closed (callbacks run in the node's thread)."""
        self._ready = True
        self._closed.wait()

    def ready(self) -> None:
        """The program has made its subscriptions: with lockstep, JOIN now (ok(), spin() and a
        Rate's sleep() say it too)."""
        self._ready = True

    def log(self, text: str) -> None:
        if self._log is not None:
            self._log(text)
        else:
            print(f"[{self.name}] {text}", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        if self.clock is not None:
            self.clock.close()
            try:
                self._lockstep_send(ls.LEAVE, int(round(self.clock.now() * 1e6)))
            except (OSError, ValueError):
                pass
        if self._thread is not threading.current_thread():
            self._thread.join(2.0)
        try:
            self.conn.close()
        except OSError:
            pass

    def __enter__(self) -> "Node":
        return self

    def __exit__(self, exc_type, *exc) -> bool:
        """Close; Ctrl-C (KeyboardInterrupt) ends a node quietly, as rospy's shutdown does."""
        self.close()
        return exc_type is not None and issubclass(exc_type, KeyboardInterrupt)

    # ------------------------------------------------------------------ the thread
    def _heartbeat(self) -> None:
        tl = self.tl
        self._send_now(tl.MAVLink_heartbeat_message(tl.MAV_TYPE_ONBOARD_CONTROLLER, tl.MAV_AUTOPILOT_INVALID,
                                                    0, 0, tl.MAV_STATE_ACTIVE, 3))

    def _lockstep_send(self, kind: int, t_usec: int, round_no: int = 0) -> None:
        """TOWERLINK_LOCKSTEP to the bridge; an ACK carries the round number of the TICK it answers
        (the bridge's, in period_usec: bridge.node_lockstep)."""
        tl = self.tl
        self._send_now(tl.MAVLink_towerlink_lockstep_message(t_usec, 0, kind, ls.OTHER, round_no))

    def _join(self) -> None:
        if self._ready and time.monotonic() - self._last_tick_wall >= REJOIN_AFTER:
            self._lockstep_send(ls.JOIN, 0)

    def _on_lockstep(self, msg) -> None:
        """The bridge's TICK: run this sim time's work (callbacks are done: they came before
        it), then ACK it. A TICK that comes again is ACKed again, after what came before it."""
        if msg.kind != ls.TICK:
            return
        self._last_tick_wall = time.monotonic()
        with self._send_lock:
            self._in_tick = True
            held, self._held = self._held, []
            for m in held:                      # what the callbacks sent since the last TICK
                self.conn.mav.send(m)
        try:
            self.clock.advance(msg.time_usec / 1e6)
        finally:
            with self._send_lock:
                self._in_tick = False
        self._lockstep_send(ls.ACK, msg.time_usec, msg.period_usec)   # the round it answers

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
                self.log(f"callback {getattr(fn, '__name__', fn)!s} failed: {exc!r}{_where(exc)}")

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
            if mtype == "TOWERLINK_LOCKSTEP":
                if self.clock is not None:
                    self._call(self._on_lockstep, msg)
                continue
            for cb, sysid in [*self._subs.get(mtype, ()), *self._subs.get("*", ())]:
                if sysid is None or msg.get_srcSystem() == sysid:
                    self._call(cb, msg)
