"""What Copter and Rover autopilots share: state read-back, home, the flight modes and the one
path that changes them, and the collaborators that do the rest.

An Autopilot drives one vehicle of a batched fleet (vehicle/fleet.py) through Setpoints.
It never touches sockets: the link layer (vehicle/link/) calls `command()`, `set_mode()`,
`position_target_*()`, `gcs_heartbeat()` and the mission calls, and reads its state for
telemetry; the world calls `update(t)` at a fixed sim rate. Text for the GCS goes out through
the Outbox it is given (STATUSTEXT, MISSION_ITEM_REACHED).

Its parts: one Mode object per supported mode (mode.py; copter_modes/, rover_modes/), the
current one in `flightmode`; `arming` (arming.py), `commands` (commands.py and the vehicle's),
`failsafe` (failsafe.py and the vehicle's: GCS, battery, fence actions), `crash_check`
(crash_check.py), `speed`
(DO_CHANGE_SPEED, speed.py), `fence` (fence.py), `follow` (AP_Follow, follow_mode.py) and the
SmartRTL path `srtl` (smartrtl.py). Positions are the SITL world's NED (m, z down).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from common.frames import euler_from_quaternion
from vehicle.autopilot.arming import Arming
from vehicle.autopilot.battery import Battery
from vehicle.autopilot.commands import wire_int
from vehicle.autopilot.crash_check import CrashCheck
from vehicle.autopilot.ekf_failsafe import EkfCheck
from vehicle.autopilot.ekf_origin import EkfOrigin
from vehicle.autopilot.fence import Fence
from vehicle.autopilot.follow_mode import Follow
from vehicle.autopilot.guided import GuidedTarget
from vehicle.autopilot.mission_store import MissionStore
from vehicle.autopilot.mode import Mode
from vehicle.autopilot.outbox import Outbox
from vehicle.autopilot.params import ParamStore
from vehicle.autopilot.radio_failsafe import RadioFailsafe
from vehicle.autopilot.rc_input import COPTER_RECEIVER, RcInput
from vehicle.autopilot.smartrtl import SmartRTLPath
from vehicle.autopilot.speed import SpeedOverride
from vehicle.fleet import Setpoint

SEV_INFO, SEV_WARNING = mav.MAV_SEVERITY_INFO, mav.MAV_SEVERITY_WARNING


def _key(v) -> tuple | None:
    """A vector's values as a tuple to compare (an array's as Python floats: tuple() of an
    array makes numpy scalars, several times dearer to make and to compare)."""
    if v is None:
        return None
    return tuple(v.tolist()) if isinstance(v, np.ndarray) else tuple(v)


class Autopilot:
    """One vehicle's autopilot. Subclasses name the vehicle (kind, mav_type), its modes
    (mode_classes, the GUIDED/AUTO/RTL/SMART_RTL numbers) and its collaborators' classes, and
    say what only they know: electrical_load() (W drawn, for the battery), landed_state()
    (MAV_LANDED_STATE) and home_from_fix()."""

    kind = "?"
    mav_type = 0
    mode_classes: tuple[type[Mode], ...] = ()
    initial_mode = GUIDED = AUTO = RTL = SMART_RTL = -1
    receiver = COPTER_RECEIVER          # the simulated transmitter's resting pulses (rc_input.py)
    arming_class: type = Arming
    commands_class: type = object
    failsafe_class: type = object
    radio_failsafe_class: type = RadioFailsafe
    ekf_check_class: type = EkfCheck
    crash_check_class: type = CrashCheck
    speed_param: tuple[str, float, float, float] = ("", 1.0, 0.0, 100.0)   # name, per m/s, default, max m/s

    def __init__(self, fleet, index: int, params: ParamStore, origin: tuple[float, float, float],
                 start_ned, outbox: Outbox | None = None,
                 push_params: Callable[[dict], None] | None = None,
                 missions: MissionStore | None = None, battery: Battery | None = None) -> None:
        self.fleet = fleet
        self.i = index
        self.params = params
        # SYSID_THISMAV takes effect at boot, as ArduPilot's (a PARAM_SET is saved, not applied)
        self.boot_sysid = int(params["SYSID_THISMAV"])
        self.origin = origin
        self.start_ned = np.asarray(start_ned, float)
        # local NED (LOCAL_POSITION_NED, local targets) is centred here, set at the first fix
        self.local_origin = EkfOrigin(origin)
        # STATUSTEXT and MISSION_ITEM_REACHED go out through here (the links subscribe)
        self.outbox = outbox if outbox is not None else Outbox()
        # parameter changes (PARAM_SET, DO_CHANGE_SPEED) reach this vehicle's index only
        self.push_params = push_params or (lambda p: fleet.set_params(p, i=index))
        self.t = 0.0
        self.armed = False
        self.arm_time = 0.0
        self.auto_armed = False                      # ArduCopter's ap.auto_armed (AUTO may take off)
        self.home: np.ndarray | None = None          # world NED of home
        self.hold_pos: np.ndarray | None = None      # where the current mode holds
        self.hold_yaw: float | None = None
        self.echo: GuidedTarget | None = None        # for POSITION_TARGET_LOCAL_NED
        self.battery = battery if battery is not None else Battery()   # the pack (battery.py)
        # missions, fence and rally points; the link fills the store, AUTO flies it
        self.missions = missions if missions is not None else MissionStore()
        self.fence = Fence(self)
        self.follow = Follow(params, lambda: self.sysid, origin)     # FOLLOW mode's lead
        self.srtl = SmartRTLPath(float(params.get("SRTL_ACCURACY", 2.0)), int(params.get("SRTL_POINTS", 300)),
                                 text=self.text)
        self.speed = SpeedOverride(params, self.push_params, *self.speed_param)
        self.arming = self.arming_class(self)
        self.commands = self.commands_class(self)
        self.failsafe = self.failsafe_class(self)
        self.rc = RcInput(params, self.receiver)     # the pilot's sticks (rc_input.py)
        self.radio = self.radio_failsafe_class(self)
        self.ekf_check = self.ekf_check_class(self)      # EKF failsafe, GPS glitch (ekf_failsafe.py)
        self.crash_check = self.crash_check_class(self)  # disarms a crashed copter (crash_check.py)
        self.flightmodes: dict[int, Mode] = {}
        for cls in self.mode_classes:                # in order: AUTO takes the RTL object
            self.flightmodes[cls.number] = cls(self)
        self.guided = self.flightmodes[self.GUIDED]
        self.auto = self.flightmodes[self.AUTO]
        self.smart_rtl = self.flightmodes[self.SMART_RTL]
        self.flightmode = self.flightmodes[self.initial_mode]
        self.refresh()

    def text(self, severity: int, message: str) -> None:
        """Say a STATUSTEXT (through the outbox)."""
        self.outbox.text(severity, message)

    def item_reached(self, seq: int) -> None:
        """Say MISSION_ITEM_REACHED for item `seq` (through the outbox)."""
        self.outbox.item_reached(seq)

    # ----- state read-back ------------------------------------------------------------
    def refresh(self) -> None:
        self.pos, self.vel, self.quat, self.rates = self.fleet.estimate_rows(self.i)
        self._euler = self._lla = None
        self.est_ok = bool(self.fleet.estimate_ok(self.i))
        self.on_ground = bool(self.fleet.landed(self.i))

    _euler: tuple[float, float, float] | None = None

    @property
    def euler(self) -> tuple[float, float, float]:
        """(roll, pitch, yaw) in rad of the estimated attitude (R = Rz(yaw) Ry(pitch) Rx(roll),
        body FRD -> world NED); worked out on first use after a refresh (most ticks nobody
        asks, and a 1,000-vehicle world refreshes every vehicle every tick)."""
        e = self._euler
        if e is None:
            e = self._euler = euler_from_quaternion(self.quat)
        return e

    @property
    def yaw(self) -> float:
        """Estimated heading, rad from north, clockwise seen from above."""
        return self.euler[2]

    _lla: tuple[float, float, float] | None = None

    def lla(self, ned=None) -> tuple[float, float, float]:
        """(lat deg, lon deg, alt m AMSL) of world NED `ned`, by default of the estimate
        (worked out once per refresh: several telemetry messages want it)."""
        if ned is not None:
            return geo.ned_to_lla(self.origin, ned)
        lla = self._lla
        if lla is None:
            lla = self._lla = geo.ned_to_lla(self.origin, self.pos)
        return lla

    def ekf_origin(self) -> tuple[float, float, float] | None:
        """(lat deg, lon deg, alt m AMSL) of the local NED frame's origin once the estimator
        has set it (GPS_GLOBAL_ORIGIN), else None."""
        return self.local_origin.lla

    _home_lla: tuple | None = None         # (home NED as bytes, its lat/lon/alt)

    def home_lla(self) -> tuple[float, float, float]:
        """(lat, lon, alt AMSL) of home (of the start before home is set); kept while home's
        value stays the same (home may be changed in place)."""
        ned = self.home if self.home is not None else self.start_ned
        key = ned.tobytes()
        c = self._home_lla
        if c is None or c[0] != key:
            c = self._home_lla = (key, geo.ned_to_lla(self.origin, ned))
        return c[1]

    @property
    def sysid(self) -> int:
        """The MAVLink system id this boot runs with (SYSID_THISMAV as it was at boot)."""
        return self.boot_sysid

    def reboot(self) -> None:
        """Start this autopilot afresh, as a reboot would: parameters re-read from where they
        are kept (SYSID_THISMAV included), disarmed, initial mode, no home, no targets. The
        vehicle stays where it is; the stored missions (the vehicle's eeprom), the battery
        pack (hardware: a reboot does not recharge it) and the collaborators it was built
        with (its outbox, push_params) are kept."""
        self.battery.reboot()
        if self.armed:
            self.fleet.set_armed(self.i, False)
        self.params.reload()
        kept = dict(outbox=self.outbox, push_params=self.push_params, missions=self.missions, battery=self.battery)
        args = (self.fleet, self.i, self.params, self.origin, self.start_ned)
        self.__dict__.clear()
        type(self).__init__(self, *args, **kept)
        self.setpoint()
        self.push_params(dict(self.params.values))

    # ----- modes --------------------------------------------------------------------------
    @property
    def mode(self) -> int:
        """The current mode's number (HEARTBEAT custom_mode)."""
        return self.flightmode.number

    @property
    def mode_name(self) -> str:
        return self.flightmode.name

    def base_mode(self) -> int:
        """HEARTBEAT base_mode as ArduPilot's GCS_MAVLINK::base_mode() builds it."""
        flags = self.flightmode.base_mode_flags() | mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        return flags | (mav.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0)

    def system_status(self) -> int:
        if (self.failsafe.gcs_failsafe or self.radio.active) and self.armed:
            return mav.MAV_STATE_CRITICAL
        return mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY

    def set_mode(self, number: int, reason: str = "GCS") -> bool:
        """The one way modes change (mode.py), in ArduCopter's Copter::set_mode order: a number
        that is not a mode of this vehicle -> "No such mode N" (AP_Vehicle::notify_no_such_mode);
        the current mode -> True at once; ignore_checks = not armed: disarmed, any mode may be
        selected and the arming checks catch what is missing (Rover's Mode::enter does the
        same); armed, a mode that requires a position estimate refuses without one; then the
        new mode's init(ignore_checks). Failures are said by mode_change_failed(). Then the
        old mode's exit(), the hold point here, the new mode's enter(). `reason` is
        ArduPilot's ModeReason (it logs it; nothing here reads it)."""
        number = wire_int(number, 0, 2**32 - 1)
        if number is None:
            self.text(SEV_WARNING, "Mode change failed: bad mode number")
            return False
        new = self.flightmodes.get(number)
        if new is None:
            self.text(SEV_WARNING, f"No such mode {number}")
            return False
        if new is self.flightmode:
            return True
        ignore_checks = not self.armed
        if not ignore_checks and new.requires_position() and not self.est_ok:
            self.mode_change_failed(new, "requires position")
            return False
        if not new.init(ignore_checks):
            self.mode_change_failed(new, "init failed")
            return False
        self.flightmode.exit()
        self.flightmode = new
        self.hold_here()
        new.enter()
        self.outbox.mode(number, reason)
        return True

    def mode_change_failed(self, mode: Mode, reason: str) -> None:
        """What the vehicle says when a mode change is refused: ArduCopter's
        Copter::mode_change_failed words, "Mode change to <NAME> failed: <reason>" (Rover
        overrides)."""
        self.text(SEV_WARNING, f"Mode change to {mode.name} failed: {reason}")

    def hold_here(self) -> None:
        """Hold where the vehicle is, heading as it is (refreshed first)."""
        self.refresh()
        self.hold_pos = self.pos.copy()
        self.hold_yaw = self.yaw
        self.echo = GuidedTarget("pos", self.hold_pos.copy(), None, None, self.hold_yaw, None)

    # ----- periodic -----------------------------------------------------------------------
    def update(self, t: float) -> None:
        """One autopilot tick at sim time t (s)."""
        dt = t - self.t
        self.t = t
        self.refresh()
        if not self.local_origin.is_set and self.est_ok:
            self.local_origin.set(*self.lla())    # ArduPilot: EKF origin at the first GPS fix
        if self.home is None and self.est_ok:
            self.home = self.home_from_fix()
            self.text(SEV_INFO, "Home set")       # ArduPilot: EKF origin/home from GPS
        self.radio.update(t, self.rc.read(t))
        self.failsafe.update(t, dt)
        self.ekf_check.update(t, dt)
        self.fence.update(t)
        self.crash_check.update(dt)
        mode = self.flightmode
        mode.read_pilot_input()
        mode.run(dt)
        self.smart_rtl.save_position(t)

    # ----- what the link and the world call --------------------------------------------
    def command(self, cmd: int, p: list[float], frame: int | None = None,
                x: int | None = None, y: int | None = None) -> int:
        """COMMAND_LONG / COMMAND_INT (x, y = lat, lon * 1e7) -> MAV_RESULT."""
        return self.commands.handle(cmd, p, frame, x, y)

    def arm(self, force: bool = False) -> int:
        return self.arming.arm(force)

    def disarm(self, force: bool = False, reason: str = "") -> int:
        return self.arming.disarm(force, reason)

    def prearm_ok(self) -> bool:
        return not self.arming.prearm_failures()

    def gcs_heartbeat(self) -> None:
        self.failsafe.gcs_heartbeat()

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_LOCAL_NED: the guided mode's target; False (ignored) in other modes."""
        if not self.flightmode.in_guided_mode():
            return False
        return self.flightmode.position_target_local(frame, type_mask, p, v, a, yaw, yaw_rate)

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        """SET_POSITION_TARGET_GLOBAL_INT: the guided mode's target; False (ignored) in other modes."""
        if not self.flightmode.in_guided_mode():
            return False
        return self.flightmode.position_target_global(frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate)

    def attitude_target(self, type_mask: int, q, body_rates, thrust: float) -> bool:
        """SET_ATTITUDE_TARGET (q: w, x, y, z; body_rates: roll, pitch, yaw rad/s): the guided
        mode's target (attitude_target.py); False (ignored, as ArduPilot) in other modes."""
        if not self.flightmode.in_guided_mode():
            return False
        return self.flightmode.attitude_target(type_mask, q, body_rates, thrust)

    def mission_uploaded(self, mission_type: int) -> None:
        """A new list of `mission_type` was stored (upload, partial write or clear): AUTO sees
        a new MISSION by the store's version; the fence and rally points are read live."""

    def set_mission_current(self, seq: int) -> bool:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: False if seq is not valid."""
        return self.auto.mission.set_current(seq)

    def mission_current(self) -> tuple[int, int]:
        """(current seq, MISSION_STATE) for MISSION_CURRENT."""
        return self.auto.mission.current()

    _sp_key = None

    def setpoint(self, pos=None, vel=None, acc=None, yaw=None, yaw_rate=None, level=False,
                 roll=None, pitch=None, rates=None, thrust=None) -> None:
        """Give the fleet a Setpoint (vehicle/fleet.py; skipped when identical to the last one:
        cheap at 100 vehicles)."""
        key = (_key(pos), _key(vel), _key(acc), yaw, yaw_rate, level, roll, pitch, rates, thrust)
        if key == self._sp_key:
            return
        self._sp_key = key
        self.fleet.set_setpoint(self.i, Setpoint(pos=pos, vel=vel, acc=acc, yaw=yaw, yaw_rate=yaw_rate,
                                                 level=level, roll=roll, pitch=pitch, rates=rates, thrust=thrust))
