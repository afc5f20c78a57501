"""A small MAVLink client for scripts: connect, wait, set mode, arm, take off, go, land.

Built on pymavlink, for ArduPilot-style vehicles (the towerlink SITL, or a real
ArduPilot behind the towerlink bridge). One `Client` holds one link; it tracks
every system it hears (heartbeat, mode, armed, position, landed state, STATUSTEXT)
and its blocking calls all take a wall-clock deadline and raise a typed error
when it passes. Telemetry times are the vehicle's own (time_boot_ms, sim time);
the wall clock is only used for deadlines and resend intervals.

    from gcs.client import Client
    with Client.connect("udpout:127.0.0.1:14600") as c:
        c.wait_heartbeat(sysid=1, timeout=30)
        c.set_mode("GUIDED", sysid=1)
        c.arm(sysid=1)                      # reports PreArm: texts while it retries
        c.takeoff(9.0, sysid=1)             # NAV_TAKEOFF, waits for the height
        c.goto(10.0, 5.0, -9.0, sysid=1)    # SET_POSITION_TARGET_LOCAL_NED
        c.wait_reached((10.0, 5.0, -9.0), radius=0.5, timeout=60,
                       resend=lambda: c.goto(10.0, 5.0, -9.0, sysid=1))
        c.land(sysid=1)

Every command is re-sent until acknowledged (the link may lose packets), and
state changes (mode, armed) are confirmed from the vehicle's heartbeat, so a
lost COMMAND_ACK does not fail a command that took effect.

Signing (MAVLink 2): ``Client.connect(..., signing_key=key)`` signs every packet the
client sends (heartbeats, commands, missions, goals, lockstep JOIN/ACK/LEAVE) and accepts
only packets signed with the same key, fresh and in order (common.mavlink.signing.SignatureCheck:
signature first, then the timestamp); every other packet is dropped and counted by
reason in ``signing_refused`` (unsigned, bad_signature, replay, stale). A bridge started
with --signing-key, and vehicles given the key (``towerlink sitl --signing-key``), talk
only to such a client. Key text (passphrase or 64 hex digits) is read by
common.mavlink.signing.key_from_text, as MAVProxy's ``signing setup``.
"""
from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from common.mavlink.mavstr import mav_str  # noqa: E402
from common.mavlink.signing import UNSIGNED, SignatureCheck, setup_signing  # noqa: E402

mavlink = mavutil.mavlink

# MAV_RESULT names, for messages.
RESULT_NAMES = {
    0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED",
    4: "FAILED", 5: "IN_PROGRESS", 6: "CANCELLED",
}

# A vehicle clock (time_boot_ms) that goes back by more than this is a reboot (ms), not
# a late packet: its clock is followed from there.
REBOOT_JUMP_MS = 5000
# The signing link id a Client sends on by default: 0 is the vehicles' own (and the bridge's
# own messages'), 1 the bridge's re-packing of others' messages (a tower goal it translated goes
# to the vehicle as (link 1, 255, 190)); a third stream never looks like a replay of either.
# Not 0 also because pymavlink's mavutil adopts the link id of a signed packet from its target
# vehicle while its own is 0 (then the tower would share the bridge's link 1).
SIGNING_LINK_ID = 2
TAKEOFF_EVIDENCE_S = 3.0     # s a refused re-sent takeoff has to show a climb (see Client.takeoff)
LOCKSTEP_TIMEOUT = 15.0      # wall s a lockstep client waits for the world's next TICK
LS_JOIN, LS_ACK, LS_TICK, LS_LEAVE, LS_TOWER, LS_OTHER = 1, 2, 3, 4, 2, 3   # TOWERLINK_LOCKSTEP kind / participant

# Position-only SET_POSITION_TARGET_LOCAL_NED: ignore velocity, acceleration, yaw, yaw rate.
MASK_POS_ONLY = 0b0000_1101_1111_1000
MASK_POS_YAW = MASK_POS_ONLY & ~0b0100_0000_0000  # also command yaw


# ----------------------------------------------------------------------------- errors


class ClientError(Exception):
    """Base of every error this module raises."""


class ClientTimeout(ClientError, TimeoutError):
    """A deadline passed before the vehicle did what was asked."""


class HeartbeatTimeout(ClientTimeout):
    """No heartbeat from the system within the deadline."""


class CommandTimeout(ClientTimeout):
    """No COMMAND_ACK for a command, however often it was re-sent."""


class CommandRejected(ClientError):
    """The vehicle answered a command with a result other than ACCEPTED."""

    def __init__(self, command: int, result: int, detail: str = "") -> None:
        self.command = command
        self.result = result
        name = RESULT_NAMES.get(result, str(result))
        super().__init__(f"command {command_name(command)} rejected: {name}"
                         + (f" ({detail})" if detail else ""))


class ModeChangeError(ClientTimeout):
    """The vehicle did not report the requested mode before the deadline."""


class ArmError(ClientError):
    """Arming failed; `prearm` holds the PreArm/Arm STATUSTEXTs the vehicle sent."""

    def __init__(self, message: str, prearm: Sequence[str] = (), result: int | None = None) -> None:
        self.prearm = list(prearm)
        self.result = result
        if self.prearm:
            message += ": " + "; ".join(self.prearm)
        super().__init__(message)


class TakeoffError(ClientError):
    """Takeoff was refused or the height was not reached in time."""


class GoalTimeout(ClientTimeout):
    """The vehicle did not come within the radius of a goal before the deadline."""

    def __init__(self, goal: Sequence[float], radius: float, distance: float | None,
                 timeout: float) -> None:
        self.goal = tuple(goal)
        self.radius = radius
        self.distance = distance
        d = "no position received" if distance is None else f"last distance {distance:.2f} m"
        super().__init__(f"goal {fmt_point(goal)} not reached within {radius:g} m "
                         f"in {timeout:g} s ({d})")


def command_name(cmd: int) -> str:
    try:
        return mavlink.enums["MAV_CMD"][cmd].name
    except (KeyError, AttributeError):
        return str(cmd)


def fmt_point(p: Iterable[float]) -> str:
    return "[" + ", ".join(f"{v:.2f}" for v in p) + "]"


# ----------------------------------------------------------------------------- state


@dataclass(frozen=True)
class Position:
    """One LOCAL_POSITION_NED sample, in the link's frame (tower frame on the tower link)."""
    x: float
    y: float
    z: float
    vx: float
    vy: float
    vz: float
    time_boot_ms: int

    @property
    def t(self) -> float:
        """Vehicle (sim) time in seconds."""
        return self.time_boot_ms / 1000.0

    @property
    def xyz(self) -> tuple[float, float, float]:
        return (self.x, self.y, self.z)

    def distance_to(self, p: Sequence[float], horizontal: bool = False) -> float:
        dx, dy = self.x - p[0], self.y - p[1]
        if horizontal or len(p) < 3:
            return math.hypot(dx, dy)
        return math.sqrt(dx * dx + dy * dy + (self.z - p[2]) ** 2)


@dataclass
class SystemState:
    """What the client last heard from one system id."""
    sysid: int
    mav_type: int | None = None
    autopilot: int | None = None
    base_mode: int = 0
    custom_mode: int | None = None
    system_status: int | None = None
    heartbeat_wall: float | None = None
    position: Position | None = None
    landed_state: int | None = None   # MAV_LANDED_STATE from EXTENDED_SYS_STATE
    time_boot_ms: int = 0             # newest vehicle time seen, any message (since its last reboot)
    reboots: int = 0                  # times its clock went back by more than REBOOT_JUMP_MS
    statustexts: deque = field(default_factory=lambda: deque(maxlen=200))

    @property
    def armed(self) -> bool:
        return bool(self.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    @property
    def sim_time(self) -> float:
        return self.time_boot_ms / 1000.0

    @property
    def mode_name(self) -> str | None:
        if self.custom_mode is None or self.mav_type is None:
            return None
        names = mavutil.mode_mapping_bynumber(self.mav_type) or {}
        return names.get(self.custom_mode, f"MODE({self.custom_mode})")


@dataclass(frozen=True)
class Reached:
    """Returned by wait_reached: the first fresh sample within the radius."""
    position: Position
    distance: float


def mode_number(mode: str | int, mav_type: int | None) -> int:
    """Mode number for a name ('GUIDED') on this vehicle type; ints pass through."""
    if isinstance(mode, int):
        return mode
    names = mavutil.mode_mapping_byname(mav_type) if mav_type is not None else None
    if names is None:  # unknown type: assume copter
        names = {v: k for k, v in mavutil.mode_mapping_acm.items()}
    key = mode.upper()
    if key not in names:
        raise ClientError(f"unknown mode {mode!r} for vehicle type {mav_type}; "
                          f"known: {', '.join(sorted(names))}")
    return names[key]


# ----------------------------------------------------------------------------- client


def _default_factory(conn: str, source_system: int, source_component: int):
    """Open a pymavlink connection; with the bridge's dialect when it is installed."""
    try:  # the project dialect decodes the transform stream; optional for a GCS
        from common.mavlink import dialect as _dialect  # type: ignore
        opener = getattr(_dialect, "mavlink_connection", None) or getattr(_dialect, "connect", None)
        if opener is not None:
            return opener(conn, source_system=source_system, source_component=source_component)
    except Exception:  # noqa: BLE001 - fall back to plain ardupilotmega
        pass
    return mavutil.mavlink_connection(conn, source_system=source_system,
                                      source_component=source_component,
                                      dialect="ardupilotmega", autoreconnect=True)


def _dialect_factory(conn: str, source_system: int, source_component: int):
    from common.mavlink.dialect import mavlink_connection
    return mavlink_connection(conn, source_system=source_system, source_component=source_component,
                              autoreconnect=True)


class Client:
    """One MAVLink link with state tracking and blocking, deadline-bounded helpers."""

    def __init__(self, master: Any, *, log: Callable[[str], None] | None = None,
                 heartbeat_interval: float = 1.0, tlog: str | None = None,
                 lockstep: bool = False, lockstep_timeout: float = LOCKSTEP_TIMEOUT,
                 lockstep_target: int = 0, signing_key: bytes | None = None,
                 link_id: int = SIGNING_LINK_ID) -> None:
        self.master = master
        # 0: a participant for every vehicle (through the bridge); a sysid: for that vehicle
        # alone, on its own endpoint (the van's driver)
        self.lockstep_target = lockstep_target
        # whole-system lockstep (issue 11): the world's TICKs are this client's clock
        self.lockstep = lockstep
        self.lockstep_timeout = lockstep_timeout   # wall s without a TICK: ClientTimeout
        self.tick_usec: int | None = None         # newest TICK handled (sim us)
        self._ack_due: int | None = None          # TICK handled, ACK not yet sent
        self._acked = -1                          # newest TICK ACKed (sim us)
        self._closed = False
        self._last_join = -1e9
        self._last_tick_wall = -1e9
        self.mav = master.mav
        # packets refused by the signature check, by reason (common.mavlink.signing's names)
        self.signing_refused: dict[str, int] = {}
        self.signed = False
        if signing_key:                           # before the first packet this client sends
            self._setup_signing(bytes(signing_key), link_id)
        self.systems: dict[int, SystemState] = {}
        self.log = log or (lambda s: None)
        self.heartbeat_interval = heartbeat_interval
        self._last_hb_sent = 0.0
        self._acks: dict[tuple[int, int], tuple[int, int]] = {}  # (sysid, cmd) -> (serial, result)
        self._ack_serial = 0
        self._text_serial = 0
        self._listeners: list[Callable[[Any], None]] = []
        self._tlog = open(tlog, "ab") if tlog else None
        if self._tlog is not None:
            self.mav.set_send_callback(self._log_sent)
        self.bad_packets = 0
        self.received = 0
        self._send_heartbeat()
        if lockstep:
            self._join()

    def _now(self) -> float:
        """The clock every deadline, retry and resend of this client runs on: wall seconds,
        or with lockstep the sim time of the newest TICK (then a poll returns only at a TICK,
        so what this client decides depends on sim time alone, never on the machine's speed)."""
        if self.lockstep:
            return (self.tick_usec or 0) / 1e6
        return time.monotonic()

    def clock(self) -> float:
        """The clock a program's own deadlines and resends should run on (s): wall, or with
        lockstep the sim time of the newest TICK (so they count sim time, as the client's do)."""
        return self._now()

    def _stamp(self) -> float:
        """When a received message is noted: with lockstep, just after the newest TICK (it
        arrived after the program acted on that TICK), so `stamp > t0` means "after the call"."""
        return self._now() + (1e-6 if self.lockstep else 0.0)

    # -- construction

    @classmethod
    def connect(cls, conn: str = "udpout:127.0.0.1:14600", *, source_system: int = 255,
                source_component: int = 190, log: Callable[[str], None] | None = None,
                tlog: str | None = None, factory: Callable[..., Any] | None = None,
                lockstep: bool = False, lockstep_target: int = 0,
                signing_key: bytes | None = None, link_id: int = SIGNING_LINK_ID) -> "Client":
        """Open `conn` (pymavlink spelling: udpout:H:P, udpin:H:P, tcp:H:P) as a GCS.

        lockstep: join the world's lockstep through the bridge (TOWERLINK_LOCKSTEP, so the
        connection speaks the towerlink dialect); lockstep_target: the sysid of the one vehicle
        this client drives on that vehicle's own endpoint (0: every vehicle, through the bridge).
        Several lockstep clients of one program need a source_component each (the world tells
        participants apart by sysid and compid).

        signing_key: 32 bytes (common.mavlink.signing.key_from_text makes them from a passphrase or 64
        hex digits): sign everything sent, accept only packets signed with it (see the module
        docstring). link_id: the signing link id (0..255) of what this client sends (default
        SIGNING_LINK_ID, 2); through a signing bridge not 1, the link the bridge re-packs
        translated goals on as their sender (one stream from two senders looks like replays)."""
        if factory is None and lockstep:
            factory = _dialect_factory
        try:
            master = (factory or _default_factory)(conn, source_system, source_component)
        except OSError as exc:
            raise ClientError(f"cannot open {conn}: {exc}") from exc
        try:
            return cls(master, log=log, tlog=tlog, lockstep=lockstep, lockstep_target=lockstep_target,
                       signing_key=signing_key, link_id=link_id)
        except ClientError:
            master.close()
            raise

    def _setup_signing(self, key: bytes, link_id: int) -> None:
        """Sign what this client packs (common.mavlink.signing.setup_signing: the wall clock's timestamp),
        allow no unsigned packet, and check a signed one with common.mavlink.signing.SignatureCheck."""
        if len(key) != 32:
            raise ClientError(f"a MAVLink 2 signing key is 32 bytes, not {len(key)} "
                              "(common.mavlink.signing.key_from_text makes one from a passphrase or 64 hex digits)")
        if not 0 <= int(link_id) <= 255:
            raise ClientError(f"signing link_id {link_id} is not in 0..255")
        self._link_id = int(link_id)
        setup_signing(self.mav, key, self._link_id)
        self.mav.signing.allow_unsigned_callback = None
        # pymavlink's own check stores a new timestamp before it verifies the signature, so one
        # forged packet with a far-future stamp would lock the real sender out: ours checks the
        # signature first and shares the signing clock (what we send stays ahead of what we heard)
        check = SignatureCheck(key, clock=self.mav.signing)

        def check_signature(msgbuf: bytearray, sysid: int, compid: int) -> bool:
            why = check.check(msgbuf, sysid, compid)
            if why is not None:
                self.signing_refused[why] = self.signing_refused.get(why, 0) + 1
            return why is None

        self.mav.check_signature = check_signature
        self.signed = True

    @property
    def refused(self) -> int:
        """Packets dropped by the signature check (0 without a signing key)."""
        return sum(self.signing_refused.values())

    def signing_report(self) -> str | None:
        """'signing: N packet(s) refused (unsigned n, ...)' for a log line; None without a key."""
        if not self.signed:
            return None
        detail = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in sorted(self.signing_refused.items()))
        return f"signing: {self.refused} packet(s) refused" + (f" ({detail})" if detail else "")

    def close(self) -> None:
        """Close the link (with lockstep after a LEAVE); a second call does nothing."""
        if self._closed:
            return
        self._closed = True
        if self.lockstep:
            self._lockstep_send(LS_LEAVE, self.tick_usec or 0)
        try:
            self.master.close()
        finally:
            if self._tlog is not None:
                self._tlog.close()
                self._tlog = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- receive loop

    def add_listener(self, fn: Callable[[Any], None]) -> None:
        """Call fn(msg) for every message received (after the state is updated)."""
        self._listeners.append(fn)

    def system(self, sysid: int) -> SystemState:
        if sysid not in self.systems:
            self.systems[sysid] = SystemState(sysid)
        return self.systems[sysid]

    def poll(self, timeout: float = 0.0) -> int:
        """Receive and process messages for up to `timeout` wall seconds; returns how many.

        With lockstep: first ACK the TICK handled last (everything the program did since has
        been sent), then receive until the next TICK, whatever `timeout` says; raises
        ClientTimeout when no TICK comes for `lockstep_timeout` wall seconds."""
        if self.lockstep:
            return self._poll_tick()
        end = time.monotonic() + max(0.0, timeout)
        n = 0
        while True:
            self._maybe_heartbeat()
            remaining = end - time.monotonic()
            try:
                msg = self.master.recv_match(blocking=remaining > 0,
                                             timeout=min(max(remaining, 0.0), self.heartbeat_interval))
            except (OSError, ValueError):  # transient socket trouble: keep the deadline
                msg = None
                time.sleep(min(0.05, max(remaining, 0.0)))
            if msg is not None:
                n += 1
                self._handle(msg)
                continue
            if time.monotonic() >= end:
                return n

    # -- lockstep (issue 11)

    def _lockstep_send(self, kind: int, t_usec: int) -> None:
        send = getattr(self.mav, "towerlink_lockstep_send", None)
        if send is not None:
            who = LS_TOWER if not self.lockstep_target else LS_OTHER
            self._send(lambda: send(t_usec, self.lockstep_target, kind, who, 0))

    def _join(self) -> None:
        self._last_join = time.monotonic()
        self._lockstep_send(LS_JOIN, 0)

    def _poll_tick(self) -> int:
        self._maybe_heartbeat()                 # before the ACK: it belongs to this TICK
        if self._ack_due is not None:
            self._lockstep_send(LS_ACK, self._ack_due)
            self._acked = self._ack_due
            self._ack_due = None
        end = time.monotonic() + self.lockstep_timeout
        n = 0
        while True:
            self._maybe_heartbeat()
            # JOIN until the first TICK, and again after a second without one (a restarted
            # bridge does not know us; the world may have dropped us)
            if time.monotonic() - self._last_join >= (0.5 if self.tick_usec is None else 1.0) and \
                    time.monotonic() - self._last_tick_wall >= 1.0:
                self._join()
            try:
                msg = self.master.recv_match(blocking=True, timeout=0.1)
            except (OSError, ValueError):
                msg = None
                time.sleep(0.01)
            if msg is not None:
                n += 1
                self._handle(msg)
                if self._ack_due is not None:
                    self._last_tick_wall = time.monotonic()
                    return n
                continue
            if time.monotonic() >= end:
                raise ClientTimeout(f"lockstep: no TICK from the world in {self.lockstep_timeout:g} s")

    def _handle(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self.bad_packets += 1
            data = bytes(getattr(msg, "data", b"") or b"")
            if self.signed and getattr(msg, "reason", "") == "Invalid signature" and \
                    not (data[:1] == b"\xfd" and len(data) > 2 and data[2] & 1):
                # pymavlink refuses an unsigned packet without asking the check: counted here
                self.signing_refused[UNSIGNED] = self.signing_refused.get(UNSIGNED, 0) + 1
            return
        self.received += 1
        if self.signed:     # mavutil may have adopted the vehicle's link id (ours 0): ours stays ours
            self.mav.signing.link_id = self._link_id
        if self._tlog is not None:
            self._write_tlog(msg)
        src = msg.get_srcSystem()
        st = self.system(src)
        tb = getattr(msg, "time_boot_ms", None)
        if isinstance(tb, int):
            if tb > st.time_boot_ms:
                st.time_boot_ms = tb
            elif st.time_boot_ms - tb > REBOOT_JUMP_MS:     # its clock restarted
                self.log(f"system {src} rebooted: its clock went back from "
                         f"{st.time_boot_ms / 1000:.3f} s to {tb / 1000:.3f} s")
                st.time_boot_ms = tb
                st.reboots += 1
        if mtype == "HEARTBEAT":
            if msg.type != mavlink.MAV_TYPE_GCS and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID:
                st.mav_type, st.autopilot = msg.type, msg.autopilot
                st.base_mode, st.custom_mode = msg.base_mode, msg.custom_mode
                st.system_status = msg.system_status
                st.heartbeat_wall = self._stamp()
        elif mtype == "LOCAL_POSITION_NED":
            p = Position(msg.x, msg.y, msg.z, msg.vx, msg.vy, msg.vz, msg.time_boot_ms)
            if st.position is None or p.time_boot_ms >= st.position.time_boot_ms \
                    or st.position.time_boot_ms - p.time_boot_ms > REBOOT_JUMP_MS:  # rebooted
                st.position = p
        elif mtype == "EXTENDED_SYS_STATE":
            st.landed_state = msg.landed_state
        elif mtype == "COMMAND_ACK":
            self._ack_serial += 1
            self._acks[(src, msg.command)] = (self._ack_serial, msg.result)
        elif mtype == "TOWERLINK_LOCKSTEP" and self.lockstep and msg.kind == LS_TICK:
            if self.tick_usec is None or msg.time_usec > self.tick_usec:
                self.tick_usec = msg.time_usec
                self._ack_due = msg.time_usec
            elif self._ack_due is None and msg.time_usec <= self._acked:
                # a TICK sent again (our ACK, or the TICK after it, was lost): ACK again
                self._lockstep_send(LS_ACK, self._acked)
        elif mtype == "STATUSTEXT":
            text = mav_str(msg.text)
            self._text_serial += 1
            st.statustexts.append((self._text_serial, msg.severity, text))
        for fn in self._listeners:
            fn(msg)

    def _maybe_heartbeat(self) -> None:
        # with lockstep a sim-time second: the vehicle's GCS failsafe (FS_GCS_*) counts sim time
        now = self._now() if self.lockstep else time.monotonic()
        if now - self._last_hb_sent >= self.heartbeat_interval:
            self._send_heartbeat()

    def _send_heartbeat(self) -> None:
        self._last_hb_sent = self._now() if self.lockstep else time.monotonic()
        try:
            self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                    mavlink.MAV_STATE_ACTIVE)
        except OSError:
            pass  # peer not there yet (connection refused on loopback): try again next second

    def _write_tlog(self, msg: Any) -> None:
        import struct
        usec = int(time.time() * 1.0e6) & ~3
        self._tlog.write(struct.pack(">Q", usec) + msg.get_msgbuf())

    def _log_sent(self, msg: Any, *a: Any, **k: Any) -> None:
        if self._tlog is not None:
            self._write_tlog(msg)

    def _wait(self, cond: Callable[[], Any], timeout: float) -> Any:
        """Poll until cond() is truthy (returned) or the wall deadline passes (None)."""
        end = self._now() + timeout
        while True:
            v = cond()
            if v:
                return v
            left = end - self._now()
            if left <= 0:
                return None
            self.poll(min(left, 0.05))

    def _send(self, fn: Callable[[], None]) -> None:
        try:
            fn()
        except OSError as exc:  # e.g. ECONNREFUSED while the bridge restarts: like a lost packet
            self.log(f"send failed ({exc}); will retry")

    # -- queries

    def sim_time(self, sysid: int = 1) -> float:
        """Newest vehicle time (s) seen from sysid (time_boot_ms)."""
        return self.system(sysid).sim_time

    def position(self, sysid: int = 1) -> Position | None:
        return self.system(sysid).position

    def statustexts_since(self, serial: int, sysid: int | None = None) -> list[tuple[int, int, str]]:
        out = []
        for sid, st in self.systems.items():
            if sysid is not None and sid != sysid:
                continue
            out.extend(t for t in st.statustexts if t[0] > serial)
        return sorted(out)

    # -- blocking helpers

    def wait_heartbeat(self, sysid: int = 1, timeout: float = 30.0) -> SystemState:
        """Wait for a vehicle heartbeat from `sysid` (newer than this call)."""
        t0 = self._now()
        # (is not None: with lockstep the clock starts at 0, and "no heartbeat yet" is not "one at 0")
        st = self._wait(lambda: self.system(sysid).heartbeat_wall is not None
                        and self.system(sysid).heartbeat_wall >= t0 and self.system(sysid), timeout)
        if st is None:
            raise HeartbeatTimeout(f"no heartbeat from system {sysid} in {timeout:g} s")
        return st

    def wait_position(self, sysid: int = 1, timeout: float = 10.0, after_ms: int = -1) -> Position:
        """Wait for a LOCAL_POSITION_NED from sysid newer than after_ms."""
        def fresh():
            p = self.system(sysid).position
            return p if p is not None and p.time_boot_ms > after_ms else None
        p = self._wait(fresh, timeout)
        if p is None:
            raise ClientTimeout(f"no position from system {sysid} in {timeout:g} s")
        return p

    def command_long(self, sysid: int, command: int, params: Sequence[float] = (), *,
                     component: int = 1, timeout: float = 10.0, ack_timeout: float = 1.0,
                     accept: Iterable[int] = (mavlink.MAV_RESULT_ACCEPTED,)) -> int:
        """Send COMMAND_LONG until a COMMAND_ACK arrives; returns the result.

        A lost command or ack is re-sent after `ack_timeout` seconds of the vehicle's own
        clock (or wall time, whichever comes first): in a sped-up SITL a wall-clock retry
        would let sim-time timers (DISARM_DELAY, failsafes) run out between tries.
        Raises CommandRejected for results not in `accept`, CommandTimeout if no ack.
        """
        p = list(params) + [0.0] * (7 - len(params))
        accept = set(accept)
        end = self._now() + timeout
        confirmation = 0
        st = self.system(sysid)
        while self._now() < end:
            before = self._acks.get((sysid, command), (0, 0))[0]
            sent_ms = st.time_boot_ms
            self._send(lambda: self.mav.command_long_send(sysid, component, command, confirmation, *p))
            confirmation = min(confirmation + 1, 255)

            def acked_or_due():
                if self._acks.get((sysid, command), (0, 0))[0] > before:
                    return self._acks[(sysid, command)]
                return (sent_ms and st.time_boot_ms - sent_ms >= ack_timeout * 1000.0) and "retry"

            ack = self._wait(acked_or_due, min(ack_timeout, max(0.0, end - self._now())))
            if ack == "retry":
                continue
            if ack:
                result = ack[1]
                if result == mavlink.MAV_RESULT_IN_PROGRESS:
                    continue
                if result not in accept:
                    raise CommandRejected(command, result)
                return result
        raise CommandTimeout(f"no COMMAND_ACK from system {sysid} for "
                             f"{command_name(command)} in {timeout:g} s")

    def set_mode(self, mode: str | int, sysid: int = 1, timeout: float = 10.0) -> None:
        """Switch mode (DO_SET_MODE) and confirm from the heartbeat."""
        st = self.system(sysid)
        if st.mav_type is None:
            self.wait_heartbeat(sysid, timeout)
        number = mode_number(mode, st.mav_type)
        end = self._now() + timeout
        rejected: CommandRejected | None = None
        while self._now() < end:
            if st.custom_mode == number and (st.heartbeat_wall or 0) > 0:
                return
            try:
                self.command_long(sysid, mavlink.MAV_CMD_DO_SET_MODE,
                                  [mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number],
                                  timeout=min(2.0, max(0.1, end - self._now())))
            except CommandTimeout:
                continue
            except CommandRejected as exc:  # e.g. GUIDED before the position estimate is good
                rejected = exc
                self.poll(min(0.5, max(0.0, end - self._now())))
                continue
            # accepted: the next heartbeats show it
            t0 = self._now()
            self._wait(lambda: st.custom_mode == number and (st.heartbeat_wall or 0) > t0,
                       min(2.5, max(0.0, end - self._now())))
        if st.custom_mode == number:
            return
        raise ModeChangeError(f"system {sysid} did not enter mode {mode} in {timeout:g} s "
                              f"(reports {st.mode_name}"
                              + (f"; last answer {RESULT_NAMES.get(rejected.result)})" if rejected else ")"))

    def arm(self, sysid: int = 1, timeout: float = 30.0, retry_interval: float = 1.0,
            force: bool = False) -> None:
        """Arm, re-trying while pre-arm checks fail; each new PreArm text is logged.

        Raises ArmError (with the PreArm texts seen) at the deadline.
        """
        st = self.system(sysid)
        end = self._now() + timeout
        serial = self._text_serial
        prearm: list[str] = []
        last_result: int | None = None

        def collect() -> None:
            nonlocal serial
            for s, _sev, text in self.statustexts_since(serial, sysid):
                serial = max(serial, s)
                if text.startswith(("PreArm", "Arm")) and text not in prearm:
                    prearm.append(text)
                    self.log(f"system {sysid}: {text}")

        while self._now() < end:
            collect()
            if st.armed:
                return
            try:
                last_result = self.command_long(
                    sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, [1, 21196 if force else 0],
                    timeout=min(2.0, max(0.1, end - self._now())))
            except CommandRejected as exc:
                last_result = exc.result
                self.poll(min(retry_interval, max(0.0, end - self._now())))
                continue
            except CommandTimeout:
                continue
            t0 = self._now()
            if self._wait(lambda: st.armed and (st.heartbeat_wall or 0) > t0,
                          min(2.5, max(0.0, end - self._now()))):
                collect()
                return
        collect()
        if st.armed:
            return
        why = RESULT_NAMES.get(last_result, "no answer") if last_result is not None else "no answer"
        raise ArmError(f"system {sysid} did not arm in {timeout:g} s (last result {why})",
                       prearm, last_result)

    def disarm(self, sysid: int = 1, timeout: float = 10.0, force: bool = False) -> None:
        st = self.system(sysid)
        end = self._now() + timeout
        while self._now() < end:
            if not st.armed and st.heartbeat_wall is not None:
                return
            try:
                self.command_long(sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
                                  [0, 21196 if force else 0], timeout=2.0)
            except (CommandTimeout, CommandRejected):
                pass
            t0 = self._now()
            self._wait(lambda: not st.armed and (st.heartbeat_wall or 0) > t0, 2.0)
        raise ClientTimeout(f"system {sysid} still armed after {timeout:g} s")

    def takeoff(self, alt: float, sysid: int = 1, *, wait: bool = True, timeout: float = 60.0,
                tolerance: float = 0.5) -> Position:
        """NAV_TAKEOFF to `alt` m above the current point; wait until within `tolerance`.

        Returns the position when the height was reached (or when the command was
        accepted, with wait=False). The height is measured from where the vehicle
        stood, along the link frame's z (down).
        """
        st = self.system(sysid)
        end = self._now() + timeout
        p0 = st.position or self.wait_position(sysid, min(10.0, timeout))
        z0 = p0.z
        climbing = lambda: st.position is not None and z0 - st.position.z > min(0.5, alt / 2)  # noqa: E731
        while self._now() < end and not climbing():
            try:
                self.command_long(sysid, mavlink.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt],
                                  timeout=min(2.0, max(0.1, end - self._now())))
                break
            except CommandTimeout:
                continue
            except CommandRejected as exc:
                # a takeoff re-sent after a lost ack is refused once the vehicle has left the
                # ground (ArduPilot: it cannot take off again): fine if it climbs. It was re-sent
                # a second after the first, when a copter still spooling up may have risen only
                # centimetres, so the evidence gets TAKEOFF_EVIDENCE_S of the vehicle's time
                if self._wait(climbing, min(TAKEOFF_EVIDENCE_S, max(0.0, end - self._now()))):
                    break
                raise TakeoffError(str(exc)) from exc
        if not wait:
            return st.position or p0
        p = self._wait(lambda: st.position is not None and z0 - st.position.z >= alt - tolerance
                       and st.position, max(0.0, end - self._now()))
        if p is None:
            h = (z0 - st.position.z) if st.position else float("nan")
            raise TakeoffError(f"system {sysid} at {h:.2f} m, not {alt:g} m, after {timeout:g} s")
        return p

    def goto(self, x: float, y: float, z: float, sysid: int = 1, *, yaw: float | None = None,
             frame: int = mavlink.MAV_FRAME_LOCAL_NED, component: int = 1,
             time_boot_ms: int | None = None) -> None:
        """Send one SET_POSITION_TARGET_LOCAL_NED (position, optional yaw) in the link's frame.

        On the bridge's tower link, MAV_FRAME_LOCAL_NED means the tower frame. To name
        another frame known to the bridge use `goto_named`. The goal is stamped with
        `time_boot_ms` (default: the vehicle's newest time seen); a bridge resolves a goal
        in a moving frame at that stamp, so re-sends keep the first send's stamp.
        """
        ms = (int(self.sim_time(sysid) * 1000) if time_boot_ms is None else int(time_boot_ms)) & 0xFFFFFFFF
        mask = MASK_POS_ONLY if yaw is None else MASK_POS_YAW
        self._send(lambda: self.mav.set_position_target_local_ned_send(
            ms, sysid, component, frame, mask, x, y, z, 0, 0, 0, 0, 0, 0, yaw or 0.0, 0))

    def goto_named(self, frame_name: str, x: float, y: float, z: float, sysid: int = 1, *,
                   yaw: float | None = None, component: int = 1,
                   time_boot_ms: int | None = None) -> None:
        """A position goal in a frame named by id (any frame the bridge's buffer knows).

        Sent as the bridge dialect's TOWERLINK_POSITION_TARGET; the bridge transforms it
        to world. Needs a connection opened with the dialect (the default when
        common.mavlink.dialect is installed).
        """
        send = getattr(self.mav, "towerlink_position_target_send", None)
        if send is None:
            raise ClientError("this connection does not speak the towerlink dialect "
                              "(TOWERLINK_POSITION_TARGET); open it with common.mavlink.dialect")
        ms = (int(self.sim_time(sysid) * 1000) if time_boot_ms is None else int(time_boot_ms)) & 0xFFFFFFFF
        mask = MASK_POS_ONLY if yaw is None else MASK_POS_YAW
        fid = frame_name.encode()
        self._send(lambda: send(ms, sysid, component, fid, mask, x, y, z, 0, 0, 0, yaw or 0.0, 0))

    def wait_reached(self, goal: Sequence[float], radius: float, timeout: float, *,
                     sysid: int = 1, resend: Callable[[], None] | None = None,
                     resend_interval: float = 1.0, horizontal: bool = False,
                     after_ms: int | None = None,
                     on_sample: Callable[[Position, float], None] | None = None) -> Reached:
        """Wait until a fresh position of sysid is within `radius` of `goal`.

        Only samples stamped after `after_ms` (default: the newest vehicle time at the
        call) count, and, once the vehicle has rebooted, every sample received since
        (its clock started again). `resend` is called every `resend_interval` wall
        seconds while waiting (re-send the goal over a lossy link). Raises GoalTimeout.
        """
        st = self.system(sysid)
        after = st.time_boot_ms if after_ms is None else after_ms
        reboots, stale = st.reboots, st.position
        end = self._now() + timeout
        last_resend = self._now()
        last_seen: Position | None = None
        dist: float | None = None
        while True:
            p = st.position
            if p is not None and p is not last_seen and \
                    (p.time_boot_ms > after or (st.reboots != reboots and p is not stale)):
                last_seen = p
                dist = p.distance_to(goal, horizontal)
                if on_sample is not None:
                    on_sample(p, dist)
                if dist <= radius:
                    return Reached(p, dist)
            now = self._now()
            if now >= end:
                raise GoalTimeout(goal, radius, dist, timeout)
            if resend is not None and now - last_resend >= resend_interval:
                last_resend = now
                resend()
            self.poll(min(0.05, end - now))

    def land(self, sysid: int = 1, *, wait: bool = True, timeout: float = 90.0) -> None:
        """Switch to LAND; with wait, until the vehicle reports landed (or disarmed)."""
        self.set_mode("LAND", sysid, timeout=min(15.0, timeout))
        if wait:
            self._wait_landed(sysid, timeout)

    def rtl(self, sysid: int = 1, *, wait: bool = True, timeout: float = 180.0) -> None:
        """Switch to RTL; with wait, until the vehicle reports landed (or disarmed)."""
        self.set_mode("RTL", sysid, timeout=min(15.0, timeout))
        if wait:
            self._wait_landed(sysid, timeout)

    def _wait_landed(self, sysid: int, timeout: float) -> None:
        st = self.system(sysid)
        t0 = self._now()
        ok = self._wait(lambda: (st.heartbeat_wall or 0) > t0 and (
            not st.armed or st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND), timeout)
        if not ok:
            raise ClientTimeout(f"system {sysid} not landed after {timeout:g} s")

    def set_message_interval(self, sysid: int, msg_id: int, hz: float, timeout: float = 3.0) -> bool:
        """Ask for a stream rate (SET_MESSAGE_INTERVAL); False if not acknowledged."""
        try:
            self.command_long(sysid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                              [msg_id, 1e6 / hz if hz > 0 else -1], timeout=timeout)
            return True
        except ClientError:
            return False

    def get_param(self, name: str, sysid: int = 1, timeout: float = 5.0) -> float:
        """PARAM_REQUEST_READ by name, re-sent until PARAM_VALUE arrives."""
        got: dict[str, float] = {}

        def listen(msg: Any) -> None:
            if msg.get_type() == "PARAM_VALUE" and msg.get_srcSystem() == sysid:
                got[mav_str(msg.param_id)] = msg.param_value

        self._listeners.append(listen)
        try:
            end = self._now() + timeout
            while self._now() < end:
                self._send(lambda: self.mav.param_request_read_send(sysid, 1, name.encode(), -1))
                if self._wait(lambda: name in got, min(1.0, max(0.0, end - self._now()))):
                    return got[name]
            raise ClientTimeout(f"no PARAM_VALUE {name} from system {sysid} in {timeout:g} s")
        finally:
            self._listeners.remove(listen)
