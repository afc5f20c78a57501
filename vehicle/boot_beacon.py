"""HEARTBEATs while `towerlink sitl` boots, before the world (and its estimator's filterpy
and scipy) is loaded: a GCS sees the vehicles within a fraction of a second.

ArduPilot does the same during its long initialisation: AP_Vehicle::scheduler_delay_callback
sends a HEARTBEAT once a second while the libraries initialise. Here the boot HEARTBEAT says
MAV_STATE_BOOT (the system is booting up), custom_mode 0 and no base_mode flags but
CUSTOM_MODE_ENABLED: the vehicle's mode and parameters are not loaded yet. It goes only where a
vehicle pushes its stream (its udpout endpoints, --out): a udpin or tcpin peer has not spoken
yet. Not in lockstep: there the world's t = 0 waits for the participants anyway, and a number
of HEARTBEATs paced by the wall clock would make the recorded run depend on the machine.

A vehicle whose sysid is not yet certain (a saved SYSID_THISMAV that cannot be read) gets no
boot HEARTBEAT rather than a wrong one.
"""
from __future__ import annotations

import os
import socket
import threading

from pymavlink.dialects.v20 import ardupilotmega as mav

from common.mavlink.signing import setup_signing
from vehicle.autopilot.params import read_parm_file
from vehicle.link.endpoints import parse_endpoint
from vehicle.network_plan import NetworkPlan
from vehicle.world_config import WorldConfig

PERIOD = 1.0            # wall s between boot HEARTBEATs, as ArduPilot's delay callback
COMP_ID = mav.MAV_COMP_ID_AUTOPILOT1
MAV_TYPES = {"copter": mav.MAV_TYPE_QUADROTOR, "rover": mav.MAV_TYPE_GROUND_ROVER}


def booting_sysid(cfg: WorldConfig, kind: str, j: int, planned: int) -> int | None:
    """The sysid vehicle j of `kind` will boot with: a saved SYSID_THISMAV wins over the plan's;
    None when the saved parameters cannot be read (the world will say why)."""
    path = cfg.saved_params_path(kind, j)
    if path is None or not os.path.exists(path):
        return planned
    try:
        saved = read_parm_file(path, warn=lambda _msg: None).get("SYSID_THISMAV")
    except (OSError, ValueError):
        return None
    return planned if saved is None else int(saved)


def boot_targets(cfg: WorldConfig, plan: NetworkPlan) -> list[tuple[int, int, tuple[str, int]]]:
    """(sysid, MAV_TYPE, (host, port)) for every udpout endpoint of this process's vehicles."""
    lo, hi = cfg.share_range()
    out = []
    for v in plan.vehicles[lo:hi]:
        sysid = booting_sysid(cfg, v.kind, v.kind_index, v.sysid)
        if sysid is None:
            continue
        for spec in v.endpoints:
            kind, host, port = parse_endpoint(spec)
            if kind == "udpout":
                out.append((sysid, MAV_TYPES[v.kind], (host, port)))
    return out


class BootBeacon:
    """Sends the boot HEARTBEATs at once and then every PERIOD wall s until stop()."""

    def __init__(self, targets: list[tuple[int, int, tuple[str, int]]], signing_key: bytes | None = None) -> None:
        self._encoders: dict[int, mav.MAVLink] = {}
        self._targets = targets
        self._key = signing_key
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._sock: socket.socket | None = None
        self.sent = 0

    def _encoder(self, sysid: int) -> mav.MAVLink:
        enc = self._encoders.get(sysid)
        if enc is None:
            enc = self._encoders[sysid] = mav.MAVLink(None, srcSystem=sysid, srcComponent=COMP_ID)
            if self._key:
                setup_signing(enc, self._key)
        return enc

    def _beat(self) -> None:
        for sysid, mav_type, addr in self._targets:
            enc = self._encoder(sysid)
            msg = enc.heartbeat_encode(mav_type, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                       mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, mav.MAV_STATE_BOOT)
            try:
                self._sock.sendto(msg.pack(enc), addr)
                self.sent += 1
            except OSError:         # no route, a name that does not resolve: the world will say
                pass
            enc.seq = (enc.seq + 1) % 256

    def start(self) -> "BootBeacon":
        if not self._targets:
            return self
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._beat()
        self._thread = threading.Thread(target=self._run, name="towerlink-boot-beacon", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(PERIOD):
            self._beat()

    def stop(self) -> None:
        """No more boot HEARTBEATs (the world's links take over); idempotent."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self._sock is not None:
            self._sock.close()
            self._sock = None
