"""What a GCS asks a vehicle to do: mode, arm, disarm, take off, land, RTL.

Each is a COMMAND_LONG re-sent until acknowledged (gcs.client.commands), and the state it
changes (mode, armed, height, landed) is confirmed from the vehicle's own reports, so a lost
COMMAND_ACK does not fail a command that took effect. Deadlines are in the client's clock.
"""
from __future__ import annotations

from gcs.client.commands import Commands
from gcs.client.errors import (RESULT_NAMES, ArmError, ClientError, ClientTimeout, CommandRejected,
                               CommandTimeout, ModeChangeError, TakeoffError)
from gcs.client.link import Link
from gcs.client.mav import mavlink, mavutil
from gcs.client.state import Position
from gcs.client.telemetry import Telemetry

TAKEOFF_EVIDENCE_S = 3.0     # s a refused re-sent takeoff has to show a climb (see Action.takeoff)
FORCE_ARM_MAGIC = 21196      # COMPONENT_ARM_DISARM param2: arm or disarm without the checks


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


class Action:
    """Mode changes, arming, take-off and landing of the systems on one link."""

    def __init__(self, link: Link, commands: Commands, telemetry: Telemetry) -> None:
        self.link = link
        self.commands = commands
        self.telemetry = telemetry

    def _left(self, end: float, floor: float = 0.0) -> float:
        return max(floor, end - self.link.clock())

    def set_mode(self, mode: str | int, sysid: int = 1, timeout: float = 10.0) -> None:
        """Switch mode (DO_SET_MODE) and confirm from the heartbeat."""
        link = self.link
        st = link.system(sysid)
        if st.mav_type is None:
            self.telemetry.wait_heartbeat(sysid, timeout)
        number = mode_number(mode, st.mav_type)
        end = link.clock() + timeout
        rejected: CommandRejected | None = None
        while link.clock() < end:
            if st.custom_mode == number and (st.heartbeat_wall or 0) > 0:
                return
            try:
                self.commands.command_long(sysid, mavlink.MAV_CMD_DO_SET_MODE,
                                           [mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number],
                                           timeout=min(2.0, self._left(end, 0.1)))
            except CommandTimeout:
                continue
            except CommandRejected as exc:  # e.g. GUIDED before the position estimate is good
                rejected = exc
                link.poll(min(0.5, self._left(end)))
                continue
            # accepted: the next heartbeats show it
            t0 = link.clock()
            link.wait_until(lambda: st.custom_mode == number and (st.heartbeat_wall or 0) > t0,
                            min(2.5, self._left(end)))
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
        link = self.link
        st = link.system(sysid)
        end = link.clock() + timeout
        serial = self.telemetry.text_serial
        prearm: list[str] = []
        last_result: int | None = None

        def collect() -> None:
            nonlocal serial
            for s, _sev, text in self.telemetry.statustexts_since(serial, sysid):
                serial = max(serial, s)
                if text.startswith(("PreArm", "Arm")) and text not in prearm:
                    prearm.append(text)
                    link.log(f"system {sysid}: {text}")

        while link.clock() < end:
            collect()
            if st.armed:
                return
            try:
                last_result = self.commands.command_long(
                    sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, [1, FORCE_ARM_MAGIC if force else 0],
                    timeout=min(2.0, self._left(end, 0.1)))
            except CommandRejected as exc:
                last_result = exc.result
                link.poll(min(retry_interval, self._left(end)))
                continue
            except CommandTimeout:
                continue
            t0 = link.clock()
            if link.wait_until(lambda: st.armed and (st.heartbeat_wall or 0) > t0, min(2.5, self._left(end))):
                collect()
                return
        collect()
        if st.armed:
            return
        why = RESULT_NAMES.get(last_result, "no answer") if last_result is not None else "no answer"
        raise ArmError(f"system {sysid} did not arm in {timeout:g} s (last result {why})",
                       prearm, last_result)

    def disarm(self, sysid: int = 1, timeout: float = 10.0, force: bool = False) -> None:
        """Disarm (COMPONENT_ARM_DISARM 0) and confirm from the heartbeat; ClientTimeout if not."""
        link = self.link
        st = link.system(sysid)
        end = link.clock() + timeout
        while link.clock() < end:
            if not st.armed and st.heartbeat_wall is not None:
                return
            try:
                self.commands.command_long(sysid, mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
                                           [0, FORCE_ARM_MAGIC if force else 0], timeout=2.0)
            except (CommandTimeout, CommandRejected):
                pass
            t0 = link.clock()
            link.wait_until(lambda: not st.armed and (st.heartbeat_wall or 0) > t0, 2.0)
        raise ClientTimeout(f"system {sysid} still armed after {timeout:g} s")

    def takeoff(self, alt: float, sysid: int = 1, *, wait: bool = True, timeout: float = 60.0,
                tolerance: float = 0.5) -> Position:
        """NAV_TAKEOFF to `alt` m above the current point; wait until within `tolerance`.

        Returns the position when the height was reached (or when the command was
        accepted, with wait=False). The height is measured from where the vehicle
        stood, along the link frame's z (down).
        """
        link = self.link
        st = link.system(sysid)
        end = link.clock() + timeout
        p0 = st.position or self.telemetry.wait_position(sysid, min(10.0, timeout))
        z0 = p0.z
        climbing = lambda: st.position is not None and z0 - st.position.z > min(0.5, alt / 2)
        while link.clock() < end and not climbing():
            try:
                self.commands.command_long(sysid, mavlink.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, alt],
                                           timeout=min(2.0, self._left(end, 0.1)))
                break
            except CommandTimeout:
                continue
            except CommandRejected as exc:
                # a takeoff re-sent after a lost ack is refused once the vehicle has left the
                # ground (ArduPilot: it cannot take off again): fine if it climbs. It was re-sent
                # a second after the first, when a copter still spooling up may have risen only
                # centimetres, so the evidence gets TAKEOFF_EVIDENCE_S of the vehicle's time
                if link.wait_until(climbing, min(TAKEOFF_EVIDENCE_S, self._left(end))):
                    break
                raise TakeoffError(str(exc)) from exc
        if not wait:
            return st.position or p0
        p = link.wait_until(lambda: st.position is not None and z0 - st.position.z >= alt - tolerance
                            and st.position, self._left(end))
        if p is None:
            h = (z0 - st.position.z) if st.position else float("nan")
            raise TakeoffError(f"system {sysid} at {h:.2f} m, not {alt:g} m, after {timeout:g} s")
        return p

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
        st = self.link.system(sysid)
        t0 = self.link.clock()
        ok = self.link.wait_until(lambda: (st.heartbeat_wall or 0) > t0 and (
            not st.armed or st.landed_state == mavlink.MAV_LANDED_STATE_ON_GROUND), timeout)
        if not ok:
            raise ClientTimeout(f"system {sysid} not landed after {timeout:g} s")
