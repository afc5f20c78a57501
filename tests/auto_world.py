"""In-process World helpers for AUTO / fence / rally flight tests: a world stepped in sim
time (no sockets), a mission store filled in code, and a recorder of what the autopilot
says (STATUSTEXT), reaches (MISSION_ITEM_REACHED) and where it is every autopilot tick."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from vehicle.autopilot.mission_store import FENCE, MISSION, RALLY, MissionItem
from vehicle.world import World, WorldConfig

REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
POS_ONLY = 0b110111111000          # SET_POSITION_TARGET type_mask: position only


def hover_stick(ap) -> None:
    """The transmitter's throttle to mid stick (RC3 1500), as autotest's hover() does before
    ALT_HOLD, LOITER or POSHOLD: at the simulated receiver's resting 1000 they descend."""
    ap.rc.transmit([0, 0, 1500, 0, 0, 0, 0, 0])


class Flight:
    """One vehicle of an in-process world, with everything it says and does recorded."""

    def __init__(self, kind: str = "copter", params: dict | None = None) -> None:
        cfg = WorldConfig(drones=1 if kind == "copter" else 0, rovers=1 if kind == "rover" else 0,
                          state_dir=None, tcp_base=None, udp_base=None)
        self.world = World(cfg)
        self.v = self.world.vehicles[0]
        self.ap = self.v.ap
        self.origin = cfg.home
        self.texts: list[tuple[float, int, str]] = []
        self.reached: list[tuple[float, int]] = []
        self.track: list[tuple[float, np.ndarray, np.ndarray, int]] = []   # t, pos, vel, mission seq
        self.ap.outbox.subscribe(text=lambda sev, msg: self.texts.append((self.world.t, sev, msg)),
                                 item_reached=lambda seq: self.reached.append((self.world.t, seq)))
        for k, val in (params or {}).items():
            assert self.ap.params.set(k, val, save=False) is None, k
            self.ap.push_params({k: val})

    # ----- items ---------------------------------------------------------------------
    def at(self, n: float, e: float, alt: float, cmd: int = mav.MAV_CMD_NAV_WAYPOINT, frame: int = REL,
           mission_type: int = MISSION, **params) -> MissionItem:
        """An item at north/east metres from the world origin, alt metres (frame's reference)."""
        lat, lon, _ = geo.ned_to_lla(self.origin, [n, e, 0.0])
        return MissionItem(0, frame, cmd, x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), z=alt,
                           mission_type=mission_type, **params)

    @staticmethod
    def do(cmd: int, **params) -> MissionItem:
        return MissionItem(0, mav.MAV_FRAME_MISSION, cmd, **params)

    def upload(self, items: list[MissionItem], mission_type: int = MISSION) -> None:
        if mission_type == MISSION:
            items = [self.at(0, 0, 0)] + items          # seq 0 is home
        self.ap.missions.replace_all(mission_type, items)
        self.ap.mission_uploaded(mission_type)

    def fence(self, items: list[MissionItem]) -> None:
        self.upload(items, FENCE)

    def rally(self, items: list[MissionItem]) -> None:
        self.upload(items, RALLY)

    # ----- stepping ------------------------------------------------------------------
    def step(self, seconds: float) -> None:
        w = self.world
        end = w.steps + int(round(seconds / w.dt))
        while w.steps < end:
            w.step()
            if w.steps % w.ap_every == 0:
                self.track.append((w.t, self.ap.pos.copy(), self.ap.vel.copy(), self.ap.mission_current()[0]))

    def until(self, cond: Callable[[], bool], timeout: float, what: str = "condition") -> float:
        """Step until cond() holds; the sim time it took. AssertionError at the sim deadline."""
        t0 = self.world.t
        while not cond():
            if self.world.t - t0 > timeout:
                raise AssertionError(f"{what}: not within {timeout} s of sim time; said {self.said()[-8:]}")
            self.step(0.1)
        return self.world.t - t0

    def settle(self) -> None:
        """Until home is set (the estimator has converged)."""
        self.until(lambda: self.ap.home is not None and self.ap.prearm_ok(), 30, "home / pre-arm")

    # ----- reading -------------------------------------------------------------------
    def said(self) -> list[str]:
        return [m for _, _, m in self.texts]

    def reached_seqs(self) -> list[int]:
        return [s for _, s in self.reached]

    def pos_at(self, t: float) -> np.ndarray:
        return min(self.track, key=lambda r: abs(r[0] - t))[1]

    def ned(self, item: MissionItem) -> np.ndarray:
        home_z = float(self.ap.home[2]) if self.ap.home is not None else 0.0
        lat, lon = item.x * 1e-7, item.y * 1e-7
        p = np.array(geo.lla_to_ned(self.origin, lat, lon, self.origin[2]))
        p[2] = home_z - item.z
        return p


def airborne(f: Flight, alt: float = 10.0) -> None:
    """Settle, then GUIDED, arm and take off to `alt` m; returns once there."""
    f.settle()
    assert f.ap.set_mode(f.ap.GUIDED)
    assert f.ap.arm() == mav.MAV_RESULT_ACCEPTED
    assert f.ap.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt]) == mav.MAV_RESULT_ACCEPTED
    f.until(lambda: f.ap.pos[2] < f.ap.home[2] - alt + 0.3, 30, "takeoff")


def goto(f: Flight, n: float, e: float, d: float) -> bool:
    """A GUIDED position target, local NED (from the EKF origin); False if refused."""
    return f.ap.position_target_local(mav.MAV_FRAME_LOCAL_NED, POS_ONLY, [n, e, d], [0, 0, 0], [0, 0, 0], 0, 0)
