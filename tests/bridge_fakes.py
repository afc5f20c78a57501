"""Test doubles for the bridge tests: a fake vehicle and a fake GCS on real UDP sockets.

Both decode the towerlink dialect with pymavlink's generated code, keep every
message they receive, and let a test wait on a condition with a deadline.
"""
from __future__ import annotations

import itertools
import socket
import threading
import time
from contextlib import contextmanager

from common.mavlink.dialect import towerlink as tl
from bridge.config import BridgeConfig
from bridge.loop import Bridge
from support import wait_until


class _Out:
    def __init__(self, ep): self.ep = ep
    def write(self, b): self.ep._send_raw(b)


class Endpoint:
    """A MAVLink peer on one UDP socket (udpin: bind `port`; udpout: send to `port`).

    Keeps every datagram as received (`raw`) and every message, and counts what its
    robust parser could not make a valid message of (`bad`, the BAD_DATA it met)
    instead of hiding it: a test can tell that nothing malformed reached it."""

    def __init__(self, sysid: int, compid: int, port: int, listen: bool, name: str = "ep") -> None:
        self.name = name
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.listen = listen
        if listen:
            self.sock.bind(("127.0.0.1", port))
            self.peer = None
        else:
            self.sock.bind(("127.0.0.1", 0))
            self.peer = ("127.0.0.1", port)
        self.sock.settimeout(0.05)
        self.mav = tl.MAVLink(_Out(self), srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        self.parser = tl.MAVLink(None)
        self.parser.robust_parsing = True
        self.msgs: list = []
        self.raw: list[bytes] = []
        self.bad: list = []
        self.lock = threading.Lock()
        self.running = True
        self.handlers = []
        self.thread = threading.Thread(target=self._loop, daemon=True)
        self.thread.start()

    def _send_raw(self, b: bytes) -> None:
        if self.peer is not None:
            self.sock.sendto(bytes(b), self.peer)

    def send_bytes(self, b: bytes) -> None:
        self._send_raw(b)

    def _loop(self) -> None:
        while self.running:
            try:
                data, addr = self.sock.recvfrom(65535)
            except socket.timeout:
                continue
            except OSError:
                if not self.running:
                    return
                continue
            if self.listen:
                self.peer = addr
            with self.lock:
                self.raw.append(data)
            try:
                msgs = self.parser.parse_buffer(data) or []
            except Exception as exc:
                with self.lock:
                    self.bad.append(exc)
                continue
            for m in msgs:
                if m.get_type() == "BAD_DATA":
                    with self.lock:
                        self.bad.append(m)
                    continue
                m._recv_time = time.monotonic()
                with self.lock:
                    self.msgs.append(m)
                for h in self.handlers:
                    h(self, m)

    def of_type(self, t: str, pred=None) -> list:
        with self.lock:
            return [m for m in self.msgs if m.get_type() == t and (pred is None or pred(m))]

    def wait(self, t: str, pred=None, timeout: float = 5.0, what: str | None = None):
        return wait_until(lambda: (self.of_type(t, pred) or [None])[-1], timeout, what or f"{self.name}: {t}")

    def clear(self) -> None:
        with self.lock:
            self.msgs.clear()

    def close(self) -> None:
        self.running = False
        self.thread.join(timeout=1)
        self.sock.close()


class FakeVehicle(Endpoint):
    """Answers COMMAND_LONG (ACK; arm/mode applied), PARAM_REQUEST_READ; sends telemetry on demand."""

    def __init__(self, sysid: int, port: int, mav_type=tl.MAV_TYPE_QUADROTOR, name="vehicle") -> None:
        super().__init__(sysid, 1, port, listen=True, name=name)
        self.sysid = sysid
        self.mav_type = mav_type
        self.mode = 0
        self.armed = False
        self.params = {"WPNAV_SPEED": 500.0, "SYSID_THISMAV": float(sysid)}
        self.origin = (-35.363261, 149.165230, 584.0)     # GPS_GLOBAL_ORIGIN: one shared world
        self.handlers.append(FakeVehicle._respond)

    def _respond(self, m) -> None:
        t = m.get_type()
        if t == "COMMAND_LONG" and m.target_system in (0, self.sysid):
            if m.command == tl.MAV_CMD_COMPONENT_ARM_DISARM:
                self.armed = m.param1 > 0.5
            elif m.command == tl.MAV_CMD_DO_SET_MODE:
                self.mode = int(m.param2)
            self.mav.command_ack_send(m.command, tl.MAV_RESULT_ACCEPTED, 0, 0,
                                      m.get_srcSystem(), m.get_srcComponent())
            if m.command == tl.MAV_CMD_REQUEST_MESSAGE and int(m.param1) == 49 and self.origin:
                self.send_origin()
                return
            self.heartbeat()
        elif t == "PARAM_REQUEST_READ" and m.target_system == self.sysid:
            name = m.param_id if isinstance(m.param_id, str) else m.param_id.decode()
            if name in self.params:
                idx = list(self.params).index(name)
                self.mav.param_value_send(name.encode(), self.params[name], tl.MAV_PARAM_TYPE_REAL32,
                                          len(self.params), idx)

    def send_origin(self) -> None:
        lat, lon, alt = self.origin
        self.mav.gps_global_origin_send(int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1e3)), 0)

    def heartbeat(self) -> None:
        base = tl.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (tl.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)
        self.mav.heartbeat_send(self.mav_type, tl.MAV_AUTOPILOT_ARDUPILOTMEGA, base, self.mode,
                                tl.MAV_STATE_ACTIVE)

    def pose(self, t_ms: int, xyz, q_wxyz=(1, 0, 0, 0), vel=(0, 0, 0), att=True, pos=True) -> None:
        if pos:
            self.mav.local_position_ned_send(t_ms, *xyz, *vel)
        if att:
            self.mav.attitude_quaternion_send(t_ms, *q_wxyz, 0, 0, 0)


_marks = itertools.count(1)


def sync(sender: Endpoint, *receivers: Endpoint, timeout: float = 5.0) -> None:
    """Send a marker from `sender` through the bridge and wait until every receiver has it.

    The marker is a NAMED_VALUE_INT "sync" with a fresh value, which the bridge routes like
    any message without a target. The bridge handles packets one at a time and loopback UDP
    keeps a socket's order, so once a receiver has the marker it also has everything the
    bridge sent it before: an `assert not ep.of_type(...)` after sync() checks that nothing
    was sent, not merely that nothing has arrived yet."""
    k = next(_marks)
    sender.mav.named_value_int_send(0, b"sync", k)
    for r in receivers:
        r.wait("NAMED_VALUE_INT", lambda m: m.name == "sync" and m.value == k, timeout,
               f"sync marker {k} from {sender.name} at {r.name}")


def bridge_config(tower_port, drone_port=None, rover_port=None, **kw) -> BridgeConfig:
    from common.scenario import load_scenario
    kw.setdefault("statics", list(load_scenario().static_transforms))
    kw.setdefault("quiet", True)
    return BridgeConfig(tower=f"udpin:127.0.0.1:{tower_port}",
                        drone=f"udpout:127.0.0.1:{drone_port}" if drone_port else None,
                        rover=f"udpout:127.0.0.1:{rover_port}" if rover_port else None, **kw)


def wait_origins(bridge, *vehicles: FakeVehicle) -> None:
    """Heartbeat from each fake vehicle and wait until the bridge knows their GPS_GLOBAL_ORIGIN
    (it asks a vehicle it has heard from; without it the vehicle's frames are not in world)."""
    for v in vehicles:
        v.heartbeat()
    wait_until(lambda: all(bridge.origins.known(v.name) for v in vehicles), 5, "vehicle origins")


@contextmanager
def running_bridge(cfg: BridgeConfig):
    """A Bridge running on a thread of this process (so tests can read its counters)."""
    logs: list[str] = []
    b = Bridge(cfg, log=logs.append)
    b.logs = logs
    th = threading.Thread(target=b.run, daemon=True)
    th.start()
    try:
        yield b
    finally:
        b.stop()
        th.join(timeout=2)
        b.close()


@contextmanager
def bridge_with_fakes(rover: bool = True, out: bool = False, heartbeats: bool = True,
                      tower_heartbeat: bool = True, origins: dict | None = None, **cfg_kw):
    """A running bridge wired to a fake drone (and rover), a tower endpoint and, with
    out=True, a listener on a world-frame --out; the tower is known to the bridge, and
    with heartbeats=True the vehicles have sent one. Yields a dict with bridge, tower,
    drone, rover (or None) and out (or None); everything is closed after. Rover follow
    is off unless follow=True is given (it would send the rover goals of its own).
    tower_heartbeat=False: the tower endpoint stays silent (not yet a peer of the bridge).
    origins={"rover": (lat, lon, alt)}: where a fake vehicle booted (its GPS_GLOBAL_ORIGIN)."""
    from support import free_ports
    cfg_kw.setdefault("follow", False)
    tport, dport, rport, oport = free_ports(4)
    fakes = {"drone": FakeVehicle(1, dport, name="drone"),
             "rover": FakeVehicle(2, rport, tl.MAV_TYPE_GROUND_ROVER, name="rover") if rover else None,
             "out": Endpoint(254, 1, oport, listen=True, name="out") if out else None}
    for name, lla in (origins or {}).items():
        fakes[name].origin = lla
    if out:
        cfg_kw["outs"] = [f"udpout:127.0.0.1:{oport}"]
    cfg = bridge_config(tport, dport, rport if rover else None, **cfg_kw)
    vehicles = [v for v in (fakes["drone"], fakes["rover"]) if v is not None]
    with running_bridge(cfg) as bridge:
        tower = Endpoint(255, 190, tport, listen=False, name="tower")
        try:
            # the bridge heartbeats the vehicles first, so they learn its address
            wait_until(lambda: all(v.peer for v in vehicles), 5, "bridge reaching the vehicles")
            if heartbeats:
                wait_origins(bridge, *vehicles)
            if tower_heartbeat:
                tower.mav.heartbeat_send(tl.MAV_TYPE_GCS, tl.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                wait_until(lambda: bridge.tower.peers, 5, "tower peer known")
            yield {"bridge": bridge, "tower": tower, **fakes}
        finally:
            for e in (tower, *fakes.values()):
                if e is not None:
                    e.close()
