"""The van of a van scenario: its route as a looped mission, and the driver that sets it going.

The world flies the mission (sitl --mission); the driver, on a link of its own, puts the van in
AUTO and arms it, then keeps its link read until told to stop (with lockstep it is one of the
participants the world waits for). Its log is RUN/van.log.
"""
from __future__ import annotations

import threading
from pathlib import Path

# MAVLink's MAV_CMD and MAV_FRAME ids the mission uses
NAV_WAYPOINT, DO_JUMP, DO_CHANGE_SPEED = 16, 177, 178
FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT = 0, 3
VAN_COMPONENT = 200     # the driver's component: the world tells it from the tower's link


def van_mission(van, home: tuple[float, float, float]) -> list:
    """The van's route (world NED x, y, m, about `home` lat, lon, alt) as WPL items: home,
    DO_CHANGE_SPEED (ground speed van.speed m/s), the route, DO_JUMP back to its first point
    forever."""
    from common.geo import ned_to_lla
    from common.wpl import WplItem
    items = [WplItem(0, 1, FRAME_GLOBAL, NAV_WAYPOINT, 0, 0, 0, 0, home[0], home[1], home[2]),
             WplItem(1, 0, FRAME_GLOBAL_RELATIVE_ALT, DO_CHANGE_SPEED, 1, van.speed, -1, 0, 0, 0, 0)]
    for x, y in van.route:
        lat, lon, _alt = ned_to_lla(home, (x, y, 0.0))
        items.append(WplItem(len(items), 0, FRAME_GLOBAL_RELATIVE_ALT, NAV_WAYPOINT, 0, 0, 0, 0, lat, lon, 0.0))
    items.append(WplItem(len(items), 0, FRAME_GLOBAL_RELATIVE_ALT, DO_JUMP, 2, -1, 0, 0, 0, 0, 0))
    return items


def write_van_mission(van, home: tuple[float, float, float], path: Path) -> Path:
    """The van's mission written as a QGC WPL 110 file at `path`; returns the path."""
    from common.wpl import write
    write(str(path), van_mission(van, home))
    return path


class VanDriver(threading.Thread):
    """AUTO and arm the van on its own link (`url`), then keep the link read until stop()."""

    def __init__(self, van, url: str, log_path: Path, *, lockstep: bool = False,
                 signing_key: bytes | None = None) -> None:
        super().__init__(daemon=True, name="van-driver")
        self.van, self.url, self.log_path = van, url, log_path
        self.lockstep, self.signing_key = lockstep, signing_key
        self._stop_event = threading.Event()

    def stop(self) -> None:
        """Ask the driver to leave (it leaves the lockstep at its next TICK)."""
        self._stop_event.set()

    def run(self) -> None:
        from gcs.client import Client, ClientError
        van = self.van
        with open(self.log_path, "a") as f:
            def log(msg: str) -> None:
                f.write(f"van: {msg}\n")
                f.flush()
            try:
                # with lockstep a participant for the van alone, on the van's own endpoint
                with Client.connect(self.url, log=log, source_component=VAN_COMPONENT, lockstep=self.lockstep,
                                    lockstep_target=van.sysid, signing_key=self.signing_key) as c:
                    c.wait_heartbeat(van.sysid, timeout=60)
                    c.set_mode("AUTO", van.sysid, timeout=30)
                    c.arm(van.sysid, timeout=60)
                    log(f"AUTO and armed at t={c.sim_time(van.sysid):.2f} s: driving its route "
                        f"at {van.speed:g} m/s")
                    while not self._stop_event.is_set():
                        c.poll(0.2)
            except (ClientError, OSError) as exc:
                log(f"could not start the van: {exc}")
