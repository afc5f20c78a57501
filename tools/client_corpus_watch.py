"""A second ground station on the vehicle's UDP endpoint that records what the vehicle does
while a corpus program runs (tools.client_corpus_checks.Record).

It identifies as sysid 250 and sends TIMESYNC, never HEARTBEAT, so the vehicle's GCS failsafe
(which listens to SYSID_MYGCS, 255) sees only the program under test.
"""
from __future__ import annotations

import os
import threading
import time

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil

from tools.client_corpus_checks import Record

WATCH_SYSID = 250
_COPTER_MODES = mavutil.mode_mapping_acm      # ArduCopter's custom_mode -> name


class Watcher:
    """start() a thread that fills `record`; stop() ends it; wait_disarmed(t) for the settle."""

    def __init__(self, udp_port: int) -> None:
        self.record = Record()
        self._port = udp_port
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5.0)

    def wait_disarmed(self, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if self.record.modes and not self.record.armed_now:
                return True
            time.sleep(0.2)  # poll: the record is filled by the watcher's thread
        return not self.record.armed_now

    def _run(self) -> None:
        m = mavutil.mavlink_connection(f"udpout:127.0.0.1:{self._port}", source_system=WATCH_SYSID,
                                       source_component=mavutil.mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
        last_ping = 0.0
        try:
            while not self._stop.is_set():
                now = time.monotonic()
                if now - last_ping > 1.0:
                    m.mav.timesync_send(0, int(now * 1e9))
                    last_ping = now
                msg = m.recv_match(blocking=True, timeout=0.2)
                if msg is not None:
                    self._take(msg)
        finally:
            m.close()

    def _take(self, msg) -> None:
        t = msg.get_type()
        if msg.get_srcSystem() != 1 and t != "BAD_DATA":
            return
        rec = self.record
        rec.types.add(t)
        if t == "HEARTBEAT" and msg.get_srcComponent() == 1:
            armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            rec.heartbeat(_COPTER_MODES.get(msg.custom_mode, str(msg.custom_mode)), armed)
        elif t == "GLOBAL_POSITION_INT":
            rec.position(msg.lat * 1e-7, msg.lon * 1e-7, msg.relative_alt * 1e-3)
        elif t == "ATTITUDE":
            rec.attitude(msg.roll)
        elif t == "STATUSTEXT":
            rec.texts.append(msg.text)
