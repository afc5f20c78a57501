"""What the vehicles report, read and waited for: heartbeats, positions, times, STATUSTEXTs."""
from __future__ import annotations

from gcs.client.commands import Commands
from gcs.client.errors import ClientError, ClientTimeout, HeartbeatTimeout
from gcs.client.link import Link
from gcs.client.mav import mavlink
from gcs.client.state import Position, SystemState


class Telemetry:
    """The systems' telemetry on one link (positions in the link's frame, m, NED; vehicle time s)."""

    def __init__(self, link: Link, commands: Commands) -> None:
        self.link = link
        self.commands = commands

    def sim_time(self, sysid: int = 1) -> float:
        """Newest vehicle time (s) seen from sysid (time_boot_ms)."""
        return self.link.system(sysid).sim_time

    def position(self, sysid: int = 1) -> Position | None:
        """The newest LOCAL_POSITION_NED of sysid, or None."""
        return self.link.system(sysid).position

    @property
    def text_serial(self) -> int:
        """The serial of the newest STATUSTEXT received (for statustexts_since)."""
        return self.link.tracker.text_serial

    def statustexts_since(self, serial: int, sysid: int | None = None) -> list[tuple[int, int, str]]:
        """(serial, severity, text) of every STATUSTEXT after `serial`, of `sysid` or of all."""
        return self.link.tracker.statustexts_since(serial, sysid)

    def wait_heartbeat(self, sysid: int = 1, timeout: float = 30.0) -> SystemState:
        """Wait for a vehicle heartbeat from `sysid` (newer than this call)."""
        link = self.link
        t0 = link.clock()
        st = link.system(sysid)
        # (is not None: with lockstep the clock starts at 0, and "no heartbeat yet" is not "one at 0")
        got = link.wait_until(lambda: st.heartbeat_wall is not None and st.heartbeat_wall >= t0 and st,
                              timeout)
        if got is None:
            raise HeartbeatTimeout(f"no heartbeat from system {sysid} in {timeout:g} s")
        return got

    def wait_position(self, sysid: int = 1, timeout: float = 10.0, after_ms: int = -1) -> Position:
        """Wait for a LOCAL_POSITION_NED from sysid newer than after_ms."""
        st = self.link.system(sysid)

        def fresh():
            p = st.position
            return p if p is not None and p.time_boot_ms > after_ms else None
        p = self.link.wait_until(fresh, timeout)
        if p is None:
            raise ClientTimeout(f"no position from system {sysid} in {timeout:g} s")
        return p

    def set_message_interval(self, sysid: int, msg_id: int, hz: float, timeout: float = 3.0) -> bool:
        """Ask for a stream rate (SET_MESSAGE_INTERVAL); False if not acknowledged."""
        try:
            self.commands.command_long(sysid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                                       [msg_id, 1e6 / hz if hz > 0 else -1], timeout=timeout)
            return True
        except ClientError:
            return False
