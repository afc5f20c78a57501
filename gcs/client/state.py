"""What a client knows of each system it hears: the pure core of its receive path.

:class:`SystemTracker` takes every decoded message and keeps, per system id, the newest
heartbeat (mode, armed, type), LOCAL_POSITION_NED, landed state, vehicle time and STATUSTEXTs.
No sockets and no clocks: a heartbeat is stamped by the `stamp` function it is given (the
client's clock). Positions are in the link's frame (the tower frame on the bridge's tower
link), m, NED; vehicle times are the vehicle's own time_boot_ms.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from common.mavlink.mavstr import mav_str
from gcs.client.mav import mavlink, mavutil

# A vehicle clock (time_boot_ms) that goes back by more than this is a reboot (ms), not
# a late packet: its clock is followed from there.
REBOOT_JUMP_MS = 5000


@dataclass(frozen=True)
class Position:
    """One LOCAL_POSITION_NED sample, in the link's frame (tower frame on the tower link): m, m/s, NED."""
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
        """Distance to point `p` of the same frame, m (3-D, or north-east only)."""
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
    heartbeat_wall: float | None = None   # client clock (s) of the newest vehicle heartbeat
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
        """Newest vehicle time seen, s."""
        return self.time_boot_ms / 1000.0

    @property
    def mode_name(self) -> str | None:
        if self.custom_mode is None or self.mav_type is None:
            return None
        names = mavutil.mode_mapping_bynumber(self.mav_type) or {}
        return names.get(self.custom_mode, f"MODE({self.custom_mode})")


class SystemTracker:
    """Every system a link hears, updated from each decoded message (see the module docstring)."""

    #: the messages :meth:`note` reads beyond time_boot_ms (a client may leave the others undecoded)
    READS = frozenset(("HEARTBEAT", "LOCAL_POSITION_NED", "EXTENDED_SYS_STATE", "STATUSTEXT"))

    def __init__(self, stamp: Callable[[], float]) -> None:
        self.systems: dict[int, SystemState] = {}
        self.text_serial = 0              # STATUSTEXTs received, all systems: each one's serial
        self._stamp = stamp

    def system(self, sysid: int) -> SystemState:
        """The state of `sysid` (an empty one until it is heard)."""
        st = self.systems.get(sysid)
        if st is None:
            st = self.systems[sysid] = SystemState(sysid)
        return st

    def note(self, msg: Any, mtype: str) -> str | None:
        """Update the sender's state from `msg` (of type `mtype`); a log line when it rebooted."""
        src = msg.get_srcSystem()
        st = self.systems.get(src) or self.system(src)
        said = self.note_time(src, getattr(msg, "time_boot_ms", None))
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
        elif mtype == "STATUSTEXT":
            self.text_serial += 1
            st.statustexts.append((self.text_serial, msg.severity, mav_str(msg.text)))
        return said

    def note_time(self, src: int, tb: Any) -> str | None:
        """A message from `src` carrying time_boot_ms `tb` (ms; None or not an int: it has none):
        its newest vehicle time, or a log line when the clock went back (a reboot)."""
        if not isinstance(tb, int):
            return None
        st = self.systems.get(src) or self.system(src)
        if tb > st.time_boot_ms:
            st.time_boot_ms = tb
        elif st.time_boot_ms - tb > REBOOT_JUMP_MS:     # its clock restarted
            said = (f"system {src} rebooted: its clock went back from "
                    f"{st.time_boot_ms / 1000:.3f} s to {tb / 1000:.3f} s")
            st.time_boot_ms = tb
            st.reboots += 1
            return said
        return None

    def statustexts_since(self, serial: int, sysid: int | None = None) -> list[tuple[int, int, str]]:
        """(serial, severity, text) of every STATUSTEXT after `serial`, of `sysid` or of all."""
        out = []
        for sid, st in self.systems.items():
            if sysid is not None and sid != sysid:
                continue
            out.extend(t for t in st.statustexts if t[0] > serial)
        return sorted(out)
