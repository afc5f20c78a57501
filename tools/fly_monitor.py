"""The run monitor of `towerlink fly`: where the world and the bridge push their telemetry.

It records a tlog per link (vehicles.tlog, bridge.tlog), tracks the sim time, every vehicle's
position in world NED (m; truth from SIM_STATE, else LOCAL_POSITION_NED moved by the vehicle's
EKF origin) and the drone's scoring parameters, and can send to a vehicle through the world's
push link (the scoring parameters' requests, ArduPilot's follow driver).

Frames are cut without decoding (common.mavlink.frame_parser) and written as they came; only
what the monitor tracks is decoded, the newest pose of each vehicle only when asked for (a
snapshot), so the monitor keeps up with a world at --speedup max. With `lockstep` it is a
participant on the push link (tools.monitor_lockstep): the world waits for it, so no
telemetry the summary scores is lost to a full receive buffer, whatever the machine's load.
"""
from __future__ import annotations

import math
import selectors
import socket
import struct
import threading
import time
from pathlib import Path

from common.geo import lla_to_ned, ned_to_lla
from common.mavlink import lockstep as wire
from common.mavlink.frame_parser import FrameParser, message_table
from common.mavlink.mavstr import mav_str
from tools.monitor_lockstep import PushLockstep
from tools.run_ids import DRONE, ROVER, SCORING_PARAMS

RCVBUF = 4 << 20            # bytes: headroom for a burst (the kernel caps it at net.core.rmem_max)
_BOOT_MS = struct.Struct("<I")
# messages whose payload starts with time_boot_ms (u32), streamed every autopilot tick: the sim time
TIMED = frozenset((30, 31, 32, 33))     # ATTITUDE, ATTITUDE_QUATERNION, LOCAL_POSITION_NED, GLOBAL_POSITION_INT
MSG_LOCAL_POSITION_NED, MSG_SIM_STATE = 32, 108
# decoded on arrival: rare, and what the scoring or the progress needs
DECODED = frozenset((22, 49, 242))      # PARAM_VALUE, GPS_GLOBAL_ORIGIN, HOME_POSITION


class Monitor(threading.Thread):
    """Listens where the world and the bridge push, records a tlog per link, tracks progress."""

    def __init__(self, run_dir: Path, ports: dict[str, int], host: str = "127.0.0.1",
                 binds: dict[str, str] | None = None, signing_key: bytes | None = None,
                 lockstep: bool = False) -> None:
        """ports: link name -> UDP port ("vehicles": where the world pushes; "bridge": the
        bridge's out); lockstep: take part in the world's lockstep on the "vehicles" link."""
        super().__init__(daemon=True, name="fly-monitor")
        from common.mavlink.dialect import towerlink as tl
        self.tl = tl
        table = message_table(tl.mavlink_map)
        self.decoder = tl.MAVLink(None)
        self._snap_decoder = tl.MAVLink(None)      # snapshot() runs on the caller's thread
        self.socks: dict[str, socket.socket] = {}
        self.parsers: dict[str, FrameParser] = {}
        self.tlogs = {}
        for name, port in ports.items():
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RCVBUF)
            s.bind(((binds or {}).get(name, host), port))    # binds: a link heard from another host
            s.setblocking(False)
            self.socks[name] = s
            self.parsers[name] = FrameParser(table)
            self.tlogs[name] = open(run_dir / f"{name}.tlog", "wb")
        self.push = PushLockstep() if lockstep else None
        self.encoder = tl.MAVLink(None, srcSystem=255, srcComponent=158)
        if signing_key:     # vehicles given the key drop unsigned requests (the scoring parameters)
            from gcs.client import SIGNING_LINK_ID
            from common.mavlink.signing import setup_signing
            setup_signing(self.encoder, signing_key, SIGNING_LINK_ID)
        self._halt = threading.Event()
        self._wake, self._waker = socket.socketpair()     # stop() ends the select at once
        self.lock = threading.Lock()
        # the monitor's thread (ACKs) and the launcher's (parameter requests, the follow driver)
        # send through one signing stream: a frame must leave in the order it was signed, or the
        # vehicle refuses the older one as a replay
        self._send_lock = threading.Lock()
        self.sim_ms = 0
        self.origin: dict[int, tuple[float, float, float]] = {}
        self._newest: dict[tuple[int, int], bytes] = {}   # (sysid, msgid) -> newest frame (pose)
        self.params: dict[str, float] = {}
        self.follow = None
        self.counts = {name: 0 for name in ports}
        self.addr_of: dict[tuple[str, int], tuple] = {}   # (link, sysid) -> where it sends from
        self.listeners: dict[str, object] = {}    # link name -> callable(message), e.g. the live view

    def run(self) -> None:
        sel = selectors.DefaultSelector()
        for name, s in self.socks.items():
            sel.register(s, selectors.EVENT_READ, name)
        sel.register(self._wake, selectors.EVENT_READ, None)
        try:
            while not self._halt.is_set():
                for key, _ in sel.select(timeout=0.1):
                    name = key.data
                    if name is None:        # stop(): the halt is checked next
                        continue
                    while True:
                        try:
                            data, addr = key.fileobj.recvfrom(65535)
                        except (BlockingIOError, InterruptedError):
                            break
                        except OSError:
                            break
                        self._datagram(name, data, addr)
                if self.push is not None:       # everything that came before each TICK was read
                    for addr, t in self.push.acks():
                        self._lockstep_send(self.tl.TOWERLINK_LOCKSTEP_KIND_ACK, t, addr)
        finally:
            sel.close()

    def _lockstep_send(self, kind: int, t_usec: int, addr) -> None:
        if self.encoder.signing.sign_outgoing:
            self._send(self.tl.MAVLink_towerlink_lockstep_message(
                t_usec, 0, kind, self.tl.TOWERLINK_LOCKSTEP_PARTICIPANT_OTHER, 0), addr)
            return
        # unsigned, an ACK is on the world's TICK chain: the lockstep codec packs the same bytes
        # in half the time
        enc = self.encoder
        frame = wire.pack(kind, t_usec, participant=wire.OTHER, sysid=enc.srcSystem, compid=enc.srcComponent,
                          seq=enc.seq)
        try:
            self.socks["vehicles"].sendto(frame, addr)
        except OSError:
            pass

    def _send(self, msg, addr) -> bool:
        """`msg` packed with the monitor's encoder and sent to `addr` under the send lock (see
        __init__); False if the socket refused it."""
        try:
            with self._send_lock:
                self.socks["vehicles"].sendto(msg.pack(self.encoder), addr)
        except OSError:
            return False
        return True

    def _datagram(self, name: str, data: bytes, addr=None) -> None:
        if self.push is not None and name == "vehicles":
            m, data = wire.unpack(data)         # the world's TICK: its own datagram, never recorded
            if m is not None and m.kind == wire.TICK and addr is not None:
                self.push.on_tick(addr, m.time_usec)
        packets = self.parsers[name].feed(data, datagram=True)
        if not packets:
            return
        usec = struct.pack(">Q", int(time.time() * 1e6) & ~3)
        f = self.tlogs[name]
        f.write(b"".join(usec + p.raw for p in packets))
        self.counts[name] += len(packets)
        listener = self.listeners.get(name)
        for p in packets:
            if addr is not None:
                self.addr_of[(name, p.sysid)] = addr
            self._track(p)
            if listener is not None:
                try:
                    listener(self._decode(p.raw))
                except Exception:  # noqa: BLE001 - a viewer's fault must not stop the recording
                    self.listeners.pop(name, None)
                    listener = None
        if self.push is not None and name == "vehicles" and addr is not None \
                and self.push.heard(addr, time.monotonic()):
            self._lockstep_send(self.tl.TOWERLINK_LOCKSTEP_KIND_JOIN, 0, addr)

    def _track(self, p) -> None:
        mid, src = p.msgid, p.sysid
        if mid in TIMED:
            if src in (DRONE, ROVER):
                pay0 = 10 if p.v2 else 6
                ms = _BOOT_MS.unpack_from(p.raw[pay0:pay0 + 4].ljust(4, b"\0"))[0]    # zero-trimmed
                if ms > self.sim_ms:
                    with self.lock:
                        self.sim_ms = ms
            if mid == MSG_LOCAL_POSITION_NED:
                self._newest[(src, mid)] = p.raw
        elif mid == MSG_SIM_STATE:
            self._newest[(src, mid)] = p.raw
        elif mid in DECODED or mid == self.tl.MAVLINK_MSG_ID_TOWERLINK_FOLLOW_STATUS:
            try:
                m = self._decode(p.raw)
            except Exception:  # noqa: BLE001 - a monitor never dies of a bad packet
                return
            self._decoded(m)

    def _decoded(self, m) -> None:
        t = m.get_type()
        src = m.get_srcSystem()
        with self.lock:
            # each vehicle's local NED is centred on its own EKF origin (GPS_GLOBAL_ORIGIN, or
            # HOME_POSITION's lla less its local x, y, z); world is the drone's, as the bridge's
            if t == "HOME_POSITION" and src not in self.origin:
                self.origin[src] = ned_to_lla((m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3),
                                              (-m.x, -m.y, -m.z))
            elif t == "GPS_GLOBAL_ORIGIN":
                self.origin[src] = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
            elif t == "PARAM_VALUE" and src == DRONE:
                self.params[mav_str(m.param_id)] = float(m.param_value)
            elif t == "TOWERLINK_FOLLOW_STATUS":
                self.follow = m

    def _decode(self, raw: bytes, decoder=None):
        return (decoder or self.decoder).decode(bytearray(raw))     # pymavlink's decode appends to it

    def _pose(self, src: int) -> tuple[float, float, float] | None:
        """Vehicle `src`'s newest position in world NED, m: truth (SIM_STATE), else its estimate."""
        raw = self._newest.get((src, MSG_SIM_STATE))
        if raw is not None and DRONE in self.origin:
            m = self._decode(raw, self._snap_decoder)
            lat = m.lat_int * 1e-7 if getattr(m, "lat_int", 0) else m.lat
            lon = m.lon_int * 1e-7 if getattr(m, "lon_int", 0) else m.lon
            return lla_to_ned(self.origin[DRONE], lat, lon, m.alt)
        raw = self._newest.get((src, MSG_LOCAL_POSITION_NED))
        if raw is None:
            return None
        m = self._decode(raw, self._snap_decoder)
        off = (lla_to_ned(self.origin[DRONE], *self.origin[src])
               if DRONE in self.origin and src in self.origin else (0.0, 0.0, 0.0))
        return (m.x + off[0], m.y + off[1], m.z + off[2])

    def send_to_vehicle(self, sysid: int, msg) -> bool:
        """`msg` to vehicle `sysid` through the world's push link (its own socket); False if
        that vehicle has not been heard yet."""
        addr = self.addr_of.get(("vehicles", sysid))
        if addr is None:
            return False
        return self._send(msg, addr)

    def request_params(self, names: tuple[str, ...] = SCORING_PARAMS) -> None:
        """Ask the drone (through the world's push link, at the address the drone sends from:
        every vehicle pushes to this one socket) for the parameters the scoring needs."""
        for n in names:
            if n not in self.params:
                self.send_to_vehicle(DRONE, self.tl.MAVLink_param_request_read_message(DRONE, 1, n.encode(), -1))

    def sim_time(self) -> float:
        """The newest sim time heard from the vehicles, s."""
        with self.lock:
            return self.sim_ms / 1000.0

    def snapshot(self) -> dict:
        """{"sim": newest sim time s, "drone"/"rover": world NED m (truth, else the estimate;
        None until heard), "follow_err": their horizontal distance m (None until both)}."""
        with self.lock:
            d, r = self._pose(DRONE), self._pose(ROVER)
            err = math.hypot(d[0] - r[0], d[1] - r[1]) if d and r else None
            return {"sim": self.sim_ms / 1000.0, "drone": d, "rover": r, "follow_err": err}

    def stop(self) -> None:
        """Stop listening (LEAVE the lockstep first); close the sockets and the tlogs."""
        self._halt.set()
        try:
            self._waker.send(b"\0")
        except OSError:
            pass
        if self.is_alive():
            self.join(2.0)
        self._wake.close()
        self._waker.close()
        if self.push is not None:
            for addr in self.push.addresses():
                self._lockstep_send(self.tl.TOWERLINK_LOCKSTEP_KIND_LEAVE, 0, addr)
        for s in self.socks.values():
            s.close()
        for f in self.tlogs.values():
            f.close()
