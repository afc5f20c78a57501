"""What Copter and Rover autopilots share: state read-back, arming and pre-arm checks,
home, GUIDED targets and their timeout, commands, GCS failsafe, the battery (battery.py) and
its failsafe.

An Autopilot drives one vehicle of a batched fleet (vehicle/fleet.py) through Setpoints.
It never touches sockets: the link layer (vehicle/link/) calls `command()`,
`set_mode()`, `position_target_*()`, `gcs_heartbeat()` and reads its state for telemetry;
the world calls `update(t)` at a fixed sim rate. Text for the GCS goes out through
`self.text(severity, message)` (STATUSTEXT).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from common import geo
from common.frames import euler_from_quaternion
from vehicle.autopilot import modes
from vehicle.autopilot.auto import AutoMode
from vehicle.autopilot.ekf_origin import EkfOrigin
from vehicle.autopilot.battery import CRITICAL, Battery, action_priority
from vehicle.autopilot.fence import Fence
from vehicle.autopilot.follow_mode import Follow
from vehicle.autopilot.guided import GuidedTarget, TargetError, decode_global, decode_local
from vehicle.autopilot.mission_store import MissionStore
from vehicle.autopilot.outbox import Outbox
from vehicle.autopilot.params import ParamStore
from vehicle.autopilot.reposition import RepositionDenied
from vehicle.autopilot.reposition import decode as decode_reposition
from vehicle.fleet import Setpoint

ACCEPTED = mav.MAV_RESULT_ACCEPTED
DENIED = mav.MAV_RESULT_DENIED
FAILED = mav.MAV_RESULT_FAILED
UNSUPPORTED = mav.MAV_RESULT_UNSUPPORTED
TEMPORARILY_REJECTED = mav.MAV_RESULT_TEMPORARILY_REJECTED

FORCE_MAGIC = 21196      # ArduPilot's param2 to force arm / disarm
BATTERY_PERIOD = 0.1     # s: ArduPilot reads its battery monitor at 10 Hz

SEV_INFO = mav.MAV_SEVERITY_INFO
SEV_NOTICE = mav.MAV_SEVERITY_NOTICE
SEV_WARNING = mav.MAV_SEVERITY_WARNING
SEV_CRITICAL = mav.MAV_SEVERITY_CRITICAL


def wire_int(v: float, lo: int, hi: int) -> int | None:
    """A command parameter (float on the wire) as an integer in lo..hi, or None when it is
    NaN, infinite, fractional or out of range (the caller answers DENIED)."""
    if not math.isfinite(v) or v != round(v) or not lo <= v <= hi:
        return None
    return int(v)


def finite(p, *idx: int) -> bool:
    """True when the command parameters at `idx` (0-based) are all finite numbers."""
    return all(math.isfinite(p[i]) for i in idx)


class Autopilot:
    kind = "?"
    mav_type = 0
    mode_names: dict[int, str] = {}
    supported: set[int] = set()
    armable: set[int] = set()
    needs_position: set[int] = set()
    guided_mode = -1
    auto_mode = -1

    def __init__(self, fleet, index: int, params: ParamStore, origin: tuple[float, float, float],
                 start_ned, outbox: Outbox | None = None,
                 push_params: Callable[[dict], None] | None = None,
                 missions: MissionStore | None = None) -> None:
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
        self.mode = self.initial_mode
        self.home: np.ndarray | None = None          # world NED of home
        self.target: GuidedTarget | None = None      # active GUIDED target
        self.target_time = 0.0
        self.hold_pos: np.ndarray | None = None
        self.hold_yaw: float | None = None
        self.echo: GuidedTarget | None = None        # for POSITION_TARGET_LOCAL_NED
        self.last_gcs: float | None = None
        self.gcs_failsafe = False
        self.speed_override: float | None = None     # DO_CHANGE_SPEED (m/s)
        self.battery = Battery()                     # the pack and AP_BattMonitor (battery.py)
        self._battery_due = 0.0                      # sim s since the monitor was last read
        self.batt_fs_priority: int | None = None     # priority of the battery action taken
        self.arm_time = 0.0
        # missions, fence and rally points; the link fills the store, the runner flies it
        self.missions = missions if missions is not None else MissionStore()
        self.auto = AutoMode(self)
        self.fence = Fence(self)
        self.follow = Follow(params, lambda: self.sysid, origin)     # FOLLOW mode's lead
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
        vehicle stays where it is; the stored missions (the vehicle's eeprom) are kept; the
        collaborators it was built with (its outbox, push_params) are kept."""
        hooks = {k: self.__dict__[k] for k in ("outbox", "push_params")}
        battery = self.battery          # the pack is hardware: a reboot does not recharge it
        battery.reboot()
        args = (self.fleet, self.i, self.params, self.origin, self.start_ned)
        missions = self.missions
        if self.armed:
            self.fleet.set_armed(self.i, False)
        self.params.reload()
        self.__dict__.clear()
        type(self).__init__(self, *args, missions=missions)
        self.__dict__.update(hooks)
        self.battery = battery
        self.setpoint()
        self.push_params(dict(self.params.values))

    @property
    def mode_name(self) -> str:
        return self.mode_names.get(self.mode, str(self.mode))

    def base_mode(self) -> int:
        return modes.base_mode(self.kind, self.mode, self.armed)

    def system_status(self) -> int:
        if self.gcs_failsafe and self.armed:
            return mav.MAV_STATE_CRITICAL
        return mav.MAV_STATE_ACTIVE if self.armed else mav.MAV_STATE_STANDBY

    # ----- periodic -----------------------------------------------------------------
    def update(self, t: float) -> None:
        dt = t - self.t
        self.t = t
        self.refresh()
        if not self.local_origin.is_set and self.est_ok:
            self.local_origin.set(*self.lla())    # ArduPilot: EKF origin at the first GPS fix
        if self.home is None and self.est_ok:
            self.home = self.pos.copy()
            self.home[2] = max(self.home[2], 0.0) if self.kind == "copter" else self.home[2]
            self.text(SEV_INFO, "Home set")   # ArduPilot: EKF origin/home from GPS
        self._battery(t, dt)
        self._gcs_failsafe_check()
        self.fence.check(t)
        self.run_mode(dt)

    # ----- battery (battery.py) --------------------------------------------------------
    failsafe_priorities: tuple[int, ...] = ()      # BATT_FS_*_ACT values, highest priority first

    def _battery(self, t: float, dt: float) -> None:
        """Drain the pack by what the vehicle draws; on a new failsafe level say so in
        AP_BattMonitor's words and act as the vehicle's handle_battery_failsafe, if the
        action ranks at or above the one already taken (ArduPilot's priority list)."""
        # ArduCopter (update_batt_compass) and ArduRover (AP_BattMonitor::read) read the monitor at
        # 10 Hz; the load drawn at the reading stands for the 0.1 s since the last one
        self._battery_due += dt
        if self._battery_due < BATTERY_PERIOD - 1e-9 and dt > 0:
            return
        dt, self._battery_due = self._battery_due, 0.0
        b = self.battery
        level = b.update(t, dt, self.electrical_load() if self.armed else 0.0, self.armed, self.params.values)
        if not level:
            return
        self.text(SEV_WARNING, b.failsafe_text())
        action = int(self.params.get("BATT_FS_CRT_ACT" if level == CRITICAL else "BATT_FS_LOW_ACT", 0))
        prio = action_priority(action, self.failsafe_priorities)
        if self.batt_fs_priority is None or prio <= self.batt_fs_priority:
            self.batt_fs_priority = prio
            self.battery_failsafe_action(action)

    def electrical_load(self) -> float:
        """Electrical power (W) the armed vehicle's motors draw now (vehicle specific)."""
        return 0.0

    def battery_failsafe_action(self, action: int) -> None:
        """BATT_FS_LOW_ACT / BATT_FS_CRT_ACT (vehicle specific)."""

    @property
    def current_a(self) -> float:
        """Battery current (A) now."""
        return self.battery.current

    @property
    def consumed_mah(self) -> float:
        return self.battery.consumed_mah

    def battery_remaining(self) -> int:
        """Remaining % as the monitor reports it; -1 when it cannot tell (MAVLink's unknown)."""
        r = self.battery.remaining_pct(self.params.values)
        return -1 if r is None else r

    def battery_voltage(self) -> float:
        """Terminal voltage (V), under load."""
        return self.battery.voltage

    # ----- modes --------------------------------------------------------------------
    initial_mode = 0

    def set_mode(self, number: int, reason: str = "GCS") -> bool:
        number = wire_int(number, 0, 2**32 - 1)
        if number is None:
            self.text(SEV_WARNING, "Mode change failed: bad mode number")
            return False
        if number == self.mode and number in self.supported:
            return True
        if number not in self.supported:
            name = self.mode_names.get(number)
            if name is None:
                self.text(SEV_WARNING, f"Mode change to {number} failed: unknown mode")
            else:
                self.text(SEV_WARNING, f"Mode change to {name} failed: init failed")
            return False
        if number in self.needs_position and not self.est_ok:
            self.text(SEV_WARNING, f"Mode change to {self.mode_names[number]} failed: requires position")
            return False
        if number == self.follow_mode and not self.follow.enabled():
            self.follow_refused(number)
            return False
        if number == self.auto_mode:
            self.refresh()
            if not self.auto.init():
                self.mode_init_failed(number)
                return False
        if not self.mode_init(number):
            self.mode_init_failed(number)
            return False
        if self.mode == self.auto_mode:
            self.auto.exit()
        self.exit_mode(self.mode)
        self.mode = number
        self.enter_mode(number)
        return True

    follow_mode = -1

    def follow_refused(self, number: int) -> None:
        self.text(SEV_WARNING, "Set FOLL_ENABLE = 1")           # ArduCopter's ModeFollow::init
        self.mode_init_failed(number)
    def mode_init(self, number: int) -> bool:
        """False when mode `number` cannot start now (its init fails, as ArduPilot's Mode::init)."""
        return True

    def exit_mode(self, number: int) -> None:
        """Mode `number` is being left (its clean-up, as ArduPilot's Mode::exit)."""

    def mode_init_failed(self, number: int) -> None:
        self.text(SEV_WARNING, f"Mode change to {self.mode_names[number]} failed: init failed")

    def mode_armable(self) -> bool:
        return self.mode in self.armable

    def enter_mode(self, number: int) -> None:
        self.refresh()
        self.target = None
        self.hold_here()

    def hold_here(self) -> None:
        self.refresh()
        self.hold_pos = self.pos.copy()
        self.hold_yaw = self.yaw
        self.echo = GuidedTarget("pos", self.hold_pos.copy(), None, None, self.hold_yaw, None)

    def run_mode(self, dt: float) -> None:
        raise NotImplementedError

    # ----- arming -------------------------------------------------------------------
    def prearm_failures(self) -> list[str]:
        if self.params.get("ARMING_CHECK", 1) == 0:
            return []
        out = []
        if not self.est_ok:
            out.append("Need Position Estimate")
        elif self.home is None:
            out.append("Waiting for home")   # never long: home follows the first good estimate
        if not self.mode_armable():
            out.append("Mode not armable")
        why = self.fence.prearm_failure()
        if why:
            out.append(why)
        return out

    def prearm_ok(self) -> bool:
        return not self.prearm_failures()

    def arm(self, force: bool = False) -> int:
        if self.armed:
            return ACCEPTED
        self.refresh()
        if not force:
            fails = self.prearm_failures()
            if fails:
                for f in fails:
                    self.text(SEV_CRITICAL, f"PreArm: {f}")
                return FAILED
        if self.home is None:
            self.home = self.pos.copy()
        self.armed = True
        self.arm_time = self.t
        self.fleet.set_armed(self.i, True)
        self.hold_here()
        self.on_armed()
        self.text(SEV_INFO, "Arming motors")
        return ACCEPTED

    def on_armed(self) -> None:
        pass

    def disarm(self, force: bool = False, reason: str = "") -> int:
        if not self.armed:
            return ACCEPTED
        self.refresh()
        if not force and not self.may_disarm():
            self.text(SEV_CRITICAL, "Disarm: not landed" if self.kind == "copter" else "Disarm: moving")
            return FAILED
        self.armed = False
        self.fleet.set_armed(self.i, False)
        self.target = None
        self.auto.on_disarmed()
        self.on_disarmed()
        self.text(SEV_INFO, f"Disarming motors{': ' + reason if reason else ''}")
        return ACCEPTED

    def may_disarm(self) -> bool:
        return True

    def on_disarmed(self) -> None:
        pass

    # ----- GUIDED targets -------------------------------------------------------------
    def in_guided(self) -> bool:
        return self.mode == self.guided_mode

    def position_target_local(self, frame, type_mask, p, v, a, yaw, yaw_rate) -> bool:
        if not self.in_guided():
            return False
        self.refresh()
        # the wire's local frame is centred on this vehicle's EKF origin, the fleet's on the world
        try:
            tgt = decode_local(frame, type_mask, p, v, a, yaw, yaw_rate, self.local_origin.to_local(self.pos),
                               self.yaw)
        except TargetError as e:
            return self._refuse(str(e))
        if tgt.pos is not None:
            tgt = dataclasses.replace(tgt, pos=self.local_origin.to_world(tgt.pos))
        return self.accept_target(tgt)

    def position_target_global(self, frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate) -> bool:
        if not self.in_guided():
            return False
        self.refresh()
        home_alt = self.home_lla()[2]
        try:
            tgt = decode_global(frame, type_mask, lat_int, lon_int, alt, v, a, yaw, yaw_rate,
                                lambda la, lo, al: geo.lla_to_ned(self.origin, la, lo, al),
                                home_alt, self.yaw)
        except TargetError as e:
            return self._refuse(str(e))
        return self.accept_target(tgt)

    def _refuse(self, why: str) -> bool:
        self.text(SEV_WARNING, why)
        self.target = None
        self.hold_here()
        return False

    def accept_target(self, tgt: GuidedTarget) -> bool:
        self.target = tgt
        self.target_time = self.t
        self.echo = tgt
        return True

    def guided_timed_out(self) -> bool:
        tgt = self.target
        return (tgt is not None and tgt.kind in ("vel", "acc", "posvel")
                and self.t - self.target_time > float(self.params.get("GUID_TIMEOUT", 3.0)))

    # ----- commands -----------------------------------------------------------------
    def command(self, cmd: int, p: list[float], frame: int | None = None,
                x: int | None = None, y: int | None = None) -> int:
        """COMMAND_LONG / COMMAND_INT (x, y = lat, lon * 1e7) -> MAV_RESULT."""
        self.refresh()
        if cmd == mav.MAV_CMD_COMPONENT_ARM_DISARM:
            force = abs(p[1] - FORCE_MAGIC) < 0.5 or abs(p[1] - 2989) < 0.5
            if p[0] == 1:
                return self.arm(force)
            if p[0] == 0:
                return self.disarm(force)
            return DENIED
        if cmd == mav.MAV_CMD_DO_SET_MODE:
            base, custom = wire_int(p[0], 0, 255), wire_int(p[1], 0, 2**32 - 1)
            if base is None or custom is None:
                return DENIED             # NaN, inf or a non-integer where a mode number goes
            if base & mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return ACCEPTED if self.set_mode(custom) else FAILED
            return DENIED
        if cmd == mav.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return ACCEPTED if self.set_mode(self.rtl_mode) else FAILED
        if cmd == mav.MAV_CMD_DO_SET_HOME:
            return self.cmd_set_home(p, x, y, frame)
        if cmd == mav.MAV_CMD_DO_CHANGE_SPEED:
            return self.cmd_change_speed(p)
        if cmd == mav.MAV_CMD_MISSION_START:
            return self.cmd_mission_start(p)
        if cmd == mav.MAV_CMD_DO_PAUSE_CONTINUE:
            return self.cmd_pause_continue(p)
        if cmd == mav.MAV_CMD_DO_SET_MISSION_CURRENT:
            return ACCEPTED if self.set_mission_current(p[0]) else FAILED
        if cmd == mav.MAV_CMD_DO_FENCE_ENABLE:
            if p[0] not in (0, 1):
                return FAILED
            self.fence.set_enabled(p[0] == 1)
            return ACCEPTED
        if cmd == mav.MAV_CMD_DO_REPOSITION:
            return self.cmd_reposition(p, frame, x, y)
        if cmd == mav.MAV_CMD_DO_FLIGHTTERMINATION:
            # ArduPilot without AFS: param1 > 0.5 disarms at once (a copter falls), else FAILED
            if not finite(p, 0):
                return DENIED
            if p[0] > 0.5:
                self.disarm(force=True, reason="flight termination")
                return ACCEPTED
            return FAILED
        if cmd == mav.MAV_CMD_PREFLIGHT_CALIBRATION:
            if not finite(p, 0, 1, 2, 3, 4, 5, 6):
                return DENIED
            # ArduPilot: "*preflight*, remember?" -> TEMPORARILY_REJECTED while armed; the
            # simulated sensors need no calibration, so it succeeds at once otherwise
            if self.armed:
                return TEMPORARILY_REJECTED
            self.text(SEV_INFO, "Calibration successful")
            return ACCEPTED
        return self.vehicle_command(cmd, p, frame, x, y)

    rtl_mode = -1

    def cmd_reposition(self, p, frame, x, y) -> int:
        """MAV_CMD_DO_REPOSITION (reposition.py): the target first, then GUIDED if asked and
        needed, then the target again, as ArduCopter (a target it refuses -> FAILED)."""
        try:
            rp = decode_reposition(p, frame, x, y, self.home_lla()[2], self.in_guided())
        except RepositionDenied:
            return DENIED
        ned = np.asarray(geo.lla_to_ned(self.origin, rp.lat, rp.lon, rp.alt_amsl), float)
        tgt = GuidedTarget("pos", ned, None, None, None, None)
        if not self.in_guided():
            if not self.set_mode(self.guided_mode, "GCS"):
                return FAILED
        self.reposition_speed(rp.speed)
        return ACCEPTED if self.accept_target(tgt) else FAILED

    def reposition_speed(self, speed: float | None) -> None:
        """DO_REPOSITION's param1 (m/s or None): ArduCopter ignores it (Rover overrides)."""

    def vehicle_command(self, cmd, p, frame, x, y) -> int:
        return UNSUPPORTED

    def cmd_set_home(self, p, x, y, frame) -> int:
        if p[0] not in (0, 1):
            return DENIED             # param1 is a flag: current position (1) or the one given (0)
        if p[0] == 1:
            if not self.est_ok:
                return FAILED
            self.home = self.pos.copy()
            self.text(SEV_INFO, "Home set")
            return ACCEPTED
        lat = x * 1e-7 if x is not None else p[4]
        lon = y * 1e-7 if y is not None else p[5]
        alt = p[6]
        if not all(math.isfinite(v) for v in (lat, lon, alt)) or (lat == 0 and lon == 0) \
                or abs(lat) > 90 or abs(lon) > 180:
            return FAILED
        if frame in (mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
            alt += self.home_lla()[2]
        ned = np.asarray(geo.lla_to_ned(self.origin, lat, lon, alt))
        if np.linalg.norm(ned) > 50_000:    # ArduPilot refuses a home far from the EKF origin
            return FAILED
        self.home = ned
        self.text(SEV_INFO, "Home set")
        return ACCEPTED

    max_speed = 100.0     # m/s: DO_CHANGE_SPEED above this is refused

    def cmd_change_speed(self, p) -> int:
        speed = p[1]
        if not math.isfinite(speed) or speed > self.max_speed:
            return FAILED
        if speed == -1:
            self.speed_override = None
            self.apply_speed()
            return ACCEPTED
        if speed > 0:
            self.speed_override = float(speed)
            self.apply_speed()
            return ACCEPTED
        return FAILED

    def apply_speed(self) -> None:
        pass

    # ----- missions (the protocol side calls these; the runner overrides them) -----------
    def mission_uploaded(self, mission_type: int) -> None:
        """A new list of `mission_type` was stored (upload, partial write or clear).

        AUTO notices a new MISSION by the store's version on its next step (and restarts
        the command it flies, as ArduPilot); the fence and rally points are read live."""

    def set_mission_current(self, seq: int) -> bool:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: False if seq is not valid."""
        try:
            seq = int(seq)
        except (TypeError, ValueError, OverflowError):
            return False
        return self.auto.runner.set_current(seq)

    def mission_current(self) -> tuple[int, int]:
        """(current seq, MISSION_STATE) for MISSION_CURRENT."""
        return self.auto.runner.current_seq(), self.auto.mission_state()

    def cmd_mission_start(self, p) -> int:
        """MAV_CMD_MISSION_START: ArduPilot refuses first/last items (DENIED), else AUTO."""
        if p[0] != 0 or p[1] != 0:
            return DENIED
        if not self.set_mode(self.auto_mode):
            return FAILED
        self.auto.mission_start()
        return ACCEPTED

    def cmd_pause_continue(self, p) -> int:
        """MAV_CMD_DO_PAUSE_CONTINUE: param1 0 pause, 1 continue (AUTO waypoints, and GUIDED
        where the vehicle has guided_pause); other param1 DENIED; a mode that cannot pause:
        FAILED with ArduCopter's "Failed to pause" / "Failed to resume"."""
        if p[0] not in (0, 1):
            return DENIED
        if self.mode == self.auto_mode:
            ok = self.auto.pause() if p[0] == 0 else self.auto.resume()
        else:
            ok = self.guided_pause(p[0] == 0)
        if not ok:
            self.text(SEV_INFO, "Failed to pause" if p[0] == 0 else "Failed to resume")
        return ACCEPTED if ok else FAILED

    def guided_pause(self, pause: bool) -> bool:
        """Pause (stop and hold) or resume GUIDED's target; False where not supported."""
        return False

    def auto_fly(self, auto, dt: float) -> None:
        """Setpoints for AUTO's current sub-mode (vehicle specific)."""
        raise NotImplementedError

    def rtl_start(self) -> None:
        raise NotImplementedError

    def rtl_complete(self) -> bool:
        raise NotImplementedError

    # ----- GCS failsafe ---------------------------------------------------------------
    def gcs_heartbeat(self) -> None:
        self.last_gcs = self.t
        if self.gcs_failsafe:
            self.gcs_failsafe = False
            self.text(SEV_INFO, "GCS Failsafe Cleared")

    def _gcs_failsafe_check(self) -> None:
        enable = int(self.params.get("FS_GCS_ENABLE", 0))
        if enable == 0 or self.last_gcs is None or self.gcs_failsafe or not self.armed:
            return
        if self.t - self.last_gcs > float(self.params.get("FS_GCS_TIMEOUT", 5.0)):
            self.gcs_failsafe = True
            self.gcs_failsafe_action(enable)

    def gcs_failsafe_action(self, enable: int) -> None:
        raise NotImplementedError

    # ----- telemetry helpers ----------------------------------------------------------
    def landed_state(self) -> int:
        return mav.MAV_LANDED_STATE_ON_GROUND

    _sp_key = None

    def setpoint(self, pos=None, vel=None, acc=None, yaw=None, yaw_rate=None, level=False) -> None:
        """Give the fleet a Setpoint (skipped when identical to the last one: cheap at 100 vehicles)."""
        key = (None if pos is None else tuple(pos), None if vel is None else tuple(vel),
               None if acc is None else tuple(acc), yaw, yaw_rate, level)
        if key == self._sp_key:
            return
        self._sp_key = key
        self.fleet.set_setpoint(self.i, Setpoint(pos=pos, vel=vel, acc=acc, yaw=yaw, yaw_rate=yaw_rate,
                                                 level=level))
