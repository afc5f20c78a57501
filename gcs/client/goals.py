"""Position goals for a vehicle in GUIDED, and waiting until it gets there.

A goal is SET_POSITION_TARGET_LOCAL_NED in the link's frame (the tower frame on the bridge's
tower link) or the towerlink dialect's TOWERLINK_POSITION_TARGET in a frame named by id; m,
NED, yaw in rad. Each is stamped with a vehicle time (time_boot_ms) that a bridge resolves a
goal in a moving frame at.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from gcs.client.errors import ClientError, GoalTimeout
from gcs.client.link import Link
from gcs.client.mav import mavlink
from gcs.client.state import Position

# Position-only SET_POSITION_TARGET_LOCAL_NED: ignore velocity, acceleration, yaw, yaw rate.
MASK_POS_ONLY = 0b0000_1101_1111_1000
MASK_POS_YAW = MASK_POS_ONLY & ~0b0100_0000_0000  # also command yaw


@dataclass(frozen=True)
class Reached:
    """Returned by wait_reached: the first fresh sample within the radius (distance in m)."""
    position: Position
    distance: float


class Goals:
    """Position goals sent on one link, and the waits for them."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def _stamp_ms(self, sysid: int, time_boot_ms: int | None) -> int:
        if time_boot_ms is not None:
            return int(time_boot_ms) & 0xFFFFFFFF
        # through seconds, as goals were always stamped: for some times this is 1 ms early
        # (float rounding), which the recorded figures depend on
        return int(self.link.system(sysid).sim_time * 1000) & 0xFFFFFFFF

    def goto(self, x: float, y: float, z: float, sysid: int = 1, *, yaw: float | None = None,
             frame: int = mavlink.MAV_FRAME_LOCAL_NED, component: int = 1,
             time_boot_ms: int | None = None) -> None:
        """Send one SET_POSITION_TARGET_LOCAL_NED (position, optional yaw) in the link's frame.

        On the bridge's tower link, MAV_FRAME_LOCAL_NED means the tower frame. To name
        another frame known to the bridge use `goto_named`. The goal is stamped with
        `time_boot_ms` (default: the vehicle's newest time seen); a bridge resolves a goal
        in a moving frame at that stamp, so re-sends keep the first send's stamp.
        """
        ms = self._stamp_ms(sysid, time_boot_ms)
        mask = MASK_POS_ONLY if yaw is None else MASK_POS_YAW
        mav = self.link.mav
        self.link.send(lambda: mav.set_position_target_local_ned_send(
            ms, sysid, component, frame, mask, x, y, z, 0, 0, 0, 0, 0, 0, yaw or 0.0, 0))

    def goto_named(self, frame_name: str, x: float, y: float, z: float, sysid: int = 1, *,
                   yaw: float | None = None, component: int = 1,
                   time_boot_ms: int | None = None) -> None:
        """A position goal in a frame named by id (any frame the bridge's buffer knows).

        Sent as the bridge dialect's TOWERLINK_POSITION_TARGET; the bridge transforms it
        to world. Needs a connection opened with the dialect (the default when
        common.mavlink.dialect is installed).
        """
        send = getattr(self.link.mav, "towerlink_position_target_send", None)
        if send is None:
            raise ClientError("this connection does not speak the towerlink dialect "
                              "(TOWERLINK_POSITION_TARGET); open it with common.mavlink.dialect")
        ms = self._stamp_ms(sysid, time_boot_ms)
        mask = MASK_POS_ONLY if yaw is None else MASK_POS_YAW
        fid = frame_name.encode()
        self.link.send(lambda: send(ms, sysid, component, fid, mask, x, y, z, 0, 0, 0, yaw or 0.0, 0))

    def wait_reached(self, goal: Sequence[float], radius: float, timeout: float, *,
                     sysid: int = 1, resend: Callable[[], None] | None = None,
                     resend_interval: float = 1.0, horizontal: bool = False,
                     after_ms: int | None = None,
                     on_sample: Callable[[Position, float], None] | None = None) -> Reached:
        """Wait until a fresh position of sysid is within `radius` m of `goal` (the link's frame).

        Only samples stamped after `after_ms` (default: the newest vehicle time at the
        call) count, and, once the vehicle has rebooted, every sample received since
        (its clock started again). `resend` is called every `resend_interval` seconds of
        the client's clock while waiting (re-send the goal over a lossy link). Raises GoalTimeout.
        """
        link = self.link
        st = link.system(sysid)
        after = st.time_boot_ms if after_ms is None else after_ms
        reboots, stale = st.reboots, st.position
        end = link.clock() + timeout
        last_resend = link.clock()
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
            now = link.clock()
            if now >= end:
                raise GoalTimeout(goal, radius, dist, timeout)
            if resend is not None and now - last_resend >= resend_interval:
                last_resend = now
                resend()
            link.poll(min(0.05, end - now))
