"""The run monitor of `towerlink fly`: where the world and the bridge push their telemetry.

It records a tlog per link (vehicles.tlog, bridge.tlog), tracks the sim time, every vehicle's
position in world NED (m; truth from SIM_STATE, else LOCAL_POSITION_NED moved by the vehicle's
EKF origin) and the drone's scoring parameters, and can send to a vehicle through the world's
push link (the scoring parameters' requests, ArduPilot's follow driver).
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
from common.mavlink.mavstr import mav_str
from tools.run_data import DRONE, ROVER
from tools.run_figures import SCORING_PARAMS


class Monitor(threading.Thread):
    """Listens where the world and the bridge push, records a tlog per link, tracks progress."""

    def __init__(self, run_dir: Path, ports: dict[str, int], host: str = "127.0.0.1",
                 binds: dict[str, str] | None = None, signing_key: bytes | None = None) -> None:
        super().__init__(daemon=True, name="fly-monitor")
        from common.mavlink.dialect import towerlink as tl
        self.tl = tl
        self.socks: dict[str, socket.socket] = {}
        self.parsers = {}
        self.tlogs = {}
        for name, port in ports.items():
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            s.bind(((binds or {}).get(name, host), port))    # binds: a link heard from another host
            s.setblocking(False)
            self.socks[name] = s
            p = tl.MAVLink(None)
            p.robust_parsing = True
            self.parsers[name] = p
            self.tlogs[name] = open(run_dir / f"{name}.tlog", "wb")
        self.encoder = tl.MAVLink(None, srcSystem=255, srcComponent=158)
        if signing_key:     # vehicles given the key drop unsigned requests (the scoring parameters)
            from gcs.client import SIGNING_LINK_ID
            from common.mavlink.signing import setup_signing
            setup_signing(self.encoder, signing_key, SIGNING_LINK_ID)
        self._halt = threading.Event()
        self.lock = threading.Lock()
        self.sim_ms = 0
        self.origin: dict[int, tuple[float, float, float]] = {}
        self.truth: dict[int, tuple[float, float, float]] = {}
        self.estimate: dict[int, tuple[float, float, float]] = {}
        self.params: dict[str, float] = {}
        self.follow = None
        self.counts = {name: 0 for name in ports}
        self.addr_of: dict[tuple[str, int], tuple] = {}   # (link, sysid) -> where it sends from
        self.listeners: dict[str, object] = {}    # link name -> callable(message), e.g. the live view

    def run(self) -> None:
        sel = selectors.DefaultSelector()
        for name, s in self.socks.items():
            sel.register(s, selectors.EVENT_READ, name)
        try:
            while not self._halt.is_set():
                for key, _ in sel.select(timeout=0.1):
                    name = key.data
                    while True:
                        try:
                            data, addr = key.fileobj.recvfrom(65535)
                        except (BlockingIOError, InterruptedError):
                            break
                        except OSError:
                            break
                        self._datagram(name, data, addr)
        finally:
            sel.close()

    def _datagram(self, name: str, data: bytes, addr=None) -> None:
        try:
            msgs = self.parsers[name].parse_buffer(data) or []
        except Exception:  # noqa: BLE001 - a monitor never dies of a bad packet
            return
        usec = struct.pack(">Q", int(time.time() * 1e6) & ~3)
        f = self.tlogs[name]
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                continue
            f.write(usec + m.get_msgbuf())
            self.counts[name] += 1
            if addr is not None:
                self.addr_of[(name, m.get_srcSystem())] = addr
            self._track(m)
            listener = self.listeners.get(name)
            if listener is not None:
                try:
                    listener(m)
                except Exception:  # noqa: BLE001 - a viewer's fault must not stop the recording
                    self.listeners.pop(name, None)

    def _track(self, m) -> None:
        t = m.get_type()
        src = m.get_srcSystem()
        ms = getattr(m, "time_boot_ms", None)
        with self.lock:
            if isinstance(ms, int) and src in (DRONE, ROVER) and t != "SET_POSITION_TARGET_LOCAL_NED":
                self.sim_ms = max(self.sim_ms, ms)
            # each vehicle's local NED is centred on its own EKF origin (GPS_GLOBAL_ORIGIN, or
            # HOME_POSITION's lla less its local x, y, z); world is the drone's, as the bridge's
            if t == "HOME_POSITION" and src not in self.origin:
                self.origin[src] = ned_to_lla((m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3),
                                              (-m.x, -m.y, -m.z))
            elif t == "GPS_GLOBAL_ORIGIN":
                self.origin[src] = (m.latitude * 1e-7, m.longitude * 1e-7, m.altitude * 1e-3)
            elif t == "SIM_STATE" and DRONE in self.origin:
                lat = m.lat_int * 1e-7 if getattr(m, "lat_int", 0) else m.lat
                lon = m.lon_int * 1e-7 if getattr(m, "lon_int", 0) else m.lon
                self.truth[src] = lla_to_ned(self.origin[DRONE], lat, lon, m.alt)
            elif t == "LOCAL_POSITION_NED":
                off = (lla_to_ned(self.origin[DRONE], *self.origin[src])
                       if DRONE in self.origin and src in self.origin else (0.0, 0.0, 0.0))
                self.estimate[src] = (m.x + off[0], m.y + off[1], m.z + off[2])
            elif t == "PARAM_VALUE" and src == DRONE:
                self.params[mav_str(m.param_id)] = float(m.param_value)
            elif t == "TOWERLINK_FOLLOW_STATUS":
                self.follow = m

    def send_to_vehicle(self, sysid: int, msg) -> bool:
        """`msg` to vehicle `sysid` through the world's push link (its own socket); False if
        that vehicle has not been heard yet."""
        addr = self.addr_of.get(("vehicles", sysid))
        if addr is None:
            return False
        try:
            self.socks["vehicles"].sendto(msg.pack(self.encoder), addr)
        except OSError:
            return False
        return True

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
            d = self.truth.get(DRONE) or self.estimate.get(DRONE)
            r = self.truth.get(ROVER) or self.estimate.get(ROVER)
            err = math.hypot(d[0] - r[0], d[1] - r[1]) if d and r else None
            return {"sim": self.sim_ms / 1000.0, "drone": d, "rover": r, "follow_err": err}

    def stop(self) -> None:
        """Stop listening; close the sockets and the tlogs."""
        self._halt.set()
        if self.is_alive():
            self.join(2.0)
        for s in self.socks.values():
            s.close()
        for f in self.tlogs.values():
            f.close()
