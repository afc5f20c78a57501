"""One vehicle's onboard log, kept as ArduPilot's AP_Logger with its File backend keeps it.

When a log is open (AP_Logger_File, AP_Logger_Backend):
- a log opens at arming (LOG_DISARMED 0, the default) or at boot (LOG_DISARMED 1, 2 or 3:
  log while disarmed too); LOG_BACKEND_TYPE 0 (no File backend bit) logs nothing;
- it stays open until the vehicle reboots or the world stops, so flights of one boot share
  a log; LOG_FILE_DSRMROT 1 closes it at every disarm (one log per arming; the next one
  opens at the next arming, or at once with LOG_DISARMED);
- records are written while armed or while LOG_DISARMED is set; with LOG_DISARMED 3 a log
  that never saw the vehicle armed is discarded when it closes;
- LOG_ERASE removes every log (the open one too, which then starts afresh).

What a log holds: it opens with FMT / UNIT / MULT / FMTU, PARM for every parameter, MSG
with the banner (firmware string, system id, frame), ORGN (EKF origin, home) when set, the mode (MODE) and the whole
mission (CMD); then the 10 Hz samples (vehicle/logs/sampler.py), MSG for every
STATUSTEXT, MODE at every mode change, ARM and EV (ARMED / DISARMED) at arming, CMD when
AUTO starts a mission item.

Timestamps (TimeUS) are sim time since the world started, as every MAVLink time_boot_ms.
The logs' bytes are written by a LogWriter thread; this class does no file I/O of its own
beyond listing and reading (the MAVLink log download, vehicle/logs/transfer.py, reads
through `entries` / `read` / `erase`).
"""
from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

from vehicle.autopilot.mission_store import MISSION
from vehicle.logs import messages
from vehicle.logs.log_catalog import LogCatalog
from vehicle.logs.log_session import LogSession
from vehicle.logs.sampler import Sampler
from vehicle.logs.store import MAX_FILES, LogInfo, LogStore
from vehicle.logs.writer import LogWriter

CHECK_PERIOD = 1.0              # s: with no log open, the File backend looks once a second


class VehicleLog:
    """The onboard log of one vehicle: call `update(ap, t)` every autopilot tick."""

    def __init__(self, kind: str, folder: str | os.PathLike | Callable[[], Path], writer: LogWriter,
                 clock: Callable[[], float],
                 unix_start_us: int, banner: Callable[[], Sequence[str]], phase: int = 0, ap_rate: float = 50.0,
                 max_files: int = MAX_FILES) -> None:
        self.kind = kind
        self.store = LogStore(folder, max_files)
        self.schema = messages.schema(kind)
        self.sampler = Sampler(kind, self.schema, clock, phase, ap_rate)
        self.writer = writer
        self.clock = clock
        self.unix_start_us = unix_start_us
        self.banner = banner               # () -> the MSG lines a log starts with
        self.session: LogSession | None = None
        self._armed = False
        self._mode: int | None = None
        self._cmd_seq: int | None = None
        self._writes = False              # records go in (open, and armed or LOG_DISARMED)
        self._rotate = False              # LOG_FILE_DSRMROT: close at the next disarmed tick
        self.catalog = LogCatalog(self.store, writer)
        self._next_check = 0.0
        self._params_seen = -1            # ap.params.changes when the LOG_* parameters were last read
        self._events: list[tuple] = []    # (us, "arm" | "mode" | "text", value, extra) since the last tick

    def set_unix_start(self, unix_start_us: int) -> None:
        """The unix time (µs) of sim t = 0 (--workers: the instant the parent hands out);
        GPS records' week and ms of week follow it."""
        self.unix_start_us = unix_start_us

    # ----- what the autopilot says (its outbox) ---------------------------------------
    def text(self, severity: int, text: str) -> None:
        """A STATUSTEXT: MSG while records go in."""
        self._events.append((self._us(), "text", text, None))

    def mode_changed(self, number: int, reason: str) -> None:
        """The mode changed (set_mode, `reason` its ModeReason's name here): MODE."""
        self._events.append((self._us(), "mode", number, reason))

    def arming_changed(self, armed: bool, forced: bool, reason: str) -> None:
        """Armed or disarmed (forced or not, `reason` why it disarmed): ARM and EV; the log
        opens at arming."""
        self._events.append((self._us(), "arm", armed, (forced, reason)))

    def _us(self, t: float | None = None) -> int:
        return round((self.clock() if t is None else t) * 1e6)

    # ----- every tick ----------------------------------------------------------------
    def update(self, ap, t: float) -> None:
        """Open / close the log as arming and the LOG_* parameters say, write what happened
        since the last tick (in the order it happened) and the periodic samples."""
        armed = bool(ap.armed)
        s = self.session
        if not self._events and armed == self._armed:
            if s is None:
                if t < self._next_check:
                    return             # idle (most vehicles of a big world): one look a second
            elif self._writes and not self._rotate and ap.params.changes == self._params_seen:
                # steady (a log open and written, nothing happened, the LOG_* parameters
                # as they were): what the full pass below would do, without reading them again
                self._next_check = t + CHECK_PERIOD
                self._record(ap, s, t)
                return
        self._next_check = t + CHECK_PERIOD
        self._params_seen = ap.params.changes
        p = ap.params.values
        backend = int(p.get("LOG_BACKEND_TYPE", 1)) & 1
        disarmed_logging = int(p.get("LOG_DISARMED", 0)) != 0
        if self._events or armed != self._armed:
            self._happened(ap, armed, backend, disarmed_logging, p, t)
        if s is not None and (not backend or (self._rotate and not armed)):
            self._rotate = False
            self.stop(p)
        if self.session is None and backend and (armed or disarmed_logging) and not self.catalog.erasing:
            self.start(ap, t)
        s = self.session
        writes = s is not None and (armed or disarmed_logging)
        if self._writes and not writes and s is not None:
            s.hand_over()               # the last records of an armed period reach the disk now
        self._writes = writes
        if s is None:
            return
        if writes:
            self._record(ap, s, t)
        else:
            s.tick(t)

    def _record(self, ap, s: LogSession, t: float) -> None:
        """An autopilot tick of an open log taking records: CMD when AUTO moved on, the
        periodic sample when due, the hand-over to the writer when due."""
        self._mission_progress(ap, s, t)
        if self.sampler.due(t):
            us = self._us(t)
            s.add(self.sampler.sample(ap, us, self.unix_start_us + us))
        s.tick(t)

    def _happened(self, ap, armed: bool, backend: int, disarmed_logging: bool, p, t: float) -> None:
        """What the outbox said since the last tick (arming, mode changes, texts), in order;
        an arming change nobody told of (a reboot's fresh state) as one without a reason."""
        events, self._events = self._events, []
        if armed != self._armed and not any(e[1] == "arm" for e in events):
            events.append((self._us(t), "arm", armed, (False, "")))
        disarmed_now = False        # what a disarm says in the same tick is still written
        for us, kind, value, extra in events:
            if kind == "arm":
                self._armed = value
                disarmed_now = not value
                self._arming(ap, us, value, *extra, backend, p)
            elif self.session is None or not (self._armed or disarmed_logging or disarmed_now):
                continue                  # not written (ArduPilot's WritesOK)
            elif kind == "mode":
                self._write_mode(us, value, messages.mode_reason(extra))
            else:
                self.session.write("MSG", us, value)
        self._armed = armed

    def _arming(self, ap, us: int, armed: bool, forced: bool, reason: str, backend: int, p) -> None:
        if armed:
            if self.session is None and backend and not self.catalog.erasing:
                self.start(ap, us * 1e-6)           # PrepForArming: the log opens first
            if self.session is not None:
                self.session.armed_seen = True
        s = self.session
        if s is None:
            return
        if armed and ap.mode != self._mode:           # changed while nothing was written
            self._write_mode(us, ap.mode, messages.MODE_REASON_UNKNOWN)
        method = messages.ARM_METHOD_MAVLINK if armed else messages.disarm_method(reason)
        s.write("ARM", us, int(armed), int(p.get("ARMING_CHECK", 1)), int(forced), method)
        s.write("EV", us, messages.EV_ARMED if armed else messages.EV_DISARMED)
        if not armed and int(p.get("LOG_FILE_DSRMROT", 0)):
            self._rotate = True

    def _write_mode(self, us: int, number: int, reason: int) -> None:
        self._mode = number
        self.session.write("MODE", us, number, number, reason)

    def _mission_progress(self, ap, s: LogSession, t: float) -> None:
        """CMD when AUTO moves on to a mission item."""
        seq = ap.mission_current()[0] if ap.mode_name == "AUTO" else None
        if seq != self._cmd_seq:
            self._cmd_seq = seq
            if seq is not None:
                self._write_cmd(ap, s, self._us(t), seq)

    def _write_cmd(self, ap, s: LogSession, us: int, seq: int) -> None:
        item = ap.missions.get(seq, MISSION)
        if item is None:
            return
        s.write("CMD", us, ap.missions.count(MISSION), seq, item.command, item.param1, item.param2,
                item.param3, item.param4, item.x * 1e-7, item.y * 1e-7, item.z, item.frame)

    # ----- opening and closing ---------------------------------------------------------
    def start(self, ap, t: float) -> None:
        """Open the next log and write what a log starts with."""
        path = self.store.new_log(busy=self.catalog.busy())
        s = self.session = LogSession(path, self.schema, self.writer, t)
        self.catalog.track(s)
        us = self._us(t)
        s.add(self.schema.header(us))
        ps = ap.params
        for name in ps.names:
            s.write("PARM", us, name, float(ps[name]), float(ps.defs[name].default))
        for line in self.banner():
            s.write("MSG", us, line)
        origin = ap.ekf_origin()
        if origin is not None:
            s.write("ORGN", us, messages.ORIGIN_EKF, *origin)
        if ap.home is not None:
            s.write("ORGN", us, messages.ORIGIN_AHRS_HOME, *ap.home_lla())
        self._write_mode(us, ap.mode, messages.MODE_REASON_UNKNOWN)
        for item in ap.missions.items(MISSION):
            s.write("CMD", us, ap.missions.count(MISSION), item.seq, item.command, item.param1,
                    item.param2, item.param3, item.param4, item.x * 1e-7, item.y * 1e-7, item.z, item.frame)
        self._cmd_seq = None
        s.armed_seen = bool(ap.armed)
        s.hand_over()                   # the header is on disk at once, not a second later

    def stop(self, params=None) -> None:
        """Close the open log (reboot, world stop, LOG_FILE_DSRMROT); with LOG_DISARMED 3
        one that never saw arming is discarded."""
        s, self.session = self.session, None
        self._writes = False
        if s is None:
            return
        s.close()
        if params is not None and int(params.get("LOG_DISARMED", 0)) == 3 and not s.armed_seen:
            path = s.path
            self.writer.call(lambda: path.unlink(missing_ok=True))

    # ----- the catalog the log download reads -------------------------------------------
    def entries(self) -> list[LogInfo]:
        """The logs oldest first, sized as they will be (vehicle/logs/log_catalog.py)."""
        return self.catalog.entries()

    def read(self, list_id: int, ofs: int, count: int) -> bytes | None:
        """Bytes of list entry `list_id`; None: recorded, not on disk yet."""
        return self.catalog.read(list_id, ofs, count)

    def erase(self) -> None:
        """Erase every log; an open log closes and, if logging goes on, starts afresh when
        the erase is done."""
        if self.session is not None:
            self.session.close()
            self.session = None
            self._writes = False
        self.catalog.erase()

    @property
    def path(self) -> Path | None:
        """The open log's file, None when none is open."""
        return None if self.session is None else self.session.path
