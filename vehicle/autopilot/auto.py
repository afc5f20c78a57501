"""AUTO's mission half, shared by the copter's and the rover's AUTO mode objects
(copter_modes/auto.py, rover_modes/auto.py, both MissionModes), as ArduCopter's and
ArduRover's ModeAuto own their AP_Mission: the stored MISSION walked by a MissionRunner, each
command started and verified by auto_commands.py. How the vehicle flies each sub-mode is its
mode object's.

What the mode does around the commands (learned from ArduPilot's source, re-expressed here):
- Entering: no mission -> refused (Copter "Mode change to AUTO failed: init failed"; Rover
  "No Mission. Can't set AUTO." then "Flight mode change failed"), except a disarmed copter:
  ArduCopter's set_mode passes ignore_checks = !armed and ModeAuto::init enters with a
  mission present OR ignore_checks; arming is then refused ("PreArm: Mode requires mission",
  AP_Arming::mission_checks). A copter armed on the ground whose next navigation command
  is not a takeoff -> "Auto: Missing Takeoff Cmd" (CRITICAL), then "init failed".
  Speeds go back to the parameters' (DO_CHANGE_SPEED lasts until AUTO is entered again).
  The mission starts or resumes (MIS_RESTART) on the next step once a position is known.
- Leaving: a running mission is stopped (a later resume restarts the command it was flying).
- Mission end: copter loiters where it is (in AUTO) or disarms if landed; rover says
  "Mission Complete" and holds (MIS_DONE_BEHAVE 0).
- Upload while running a waypoint: the current command restarts, "Auto mission changed,
  restarted command" (CRITICAL).
- ArduCopter resets the mission (first item, fresh jump counts) on every disarm, ArduRover
  only on a disarm outside AUTO.
- MAV_CMD_DO_PAUSE_CONTINUE pauses a waypoint leg (not once it is reached): the vehicle holds
  (MISSION_CURRENT still says ACTIVE, as ArduPilot's), param1 1 continues.
"""
from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.auto_commands import AutoCommands
from vehicle.autopilot.mission_runner import RUNNING, MissionRunner
from vehicle.autopilot.mission_store import MISSION

SEV_NOTICE, SEV_CRITICAL = mav.MAV_SEVERITY_NOTICE, mav.MAV_SEVERITY_CRITICAL


class AutoMission(AutoCommands):
    """The mission of one autopilot `ap`; `rtl` is that vehicle's RTL mode object, which
    NAV_RETURN_TO_LAUNCH flies (start(), complete())."""

    def __init__(self, ap, rtl) -> None:
        self.ap = ap
        self.rtl = rtl
        self.copter = ap.kind == "copter"
        self.runner = MissionRunner(lambda: ap.missions.items(MISSION), self.start_command,
                                    self.verify_command, self.exit_mission, ap.text)
        self.waiting_to_start = False
        self.seen_version = ap.missions.version[MISSION]
        self.sub = "loiter"
        self.dest: np.ndarray | None = None      # current destination, world NED
        self.reached_at: float | None = None     # sim time the destination was first reached
        self.hold_s = 0.0
        self.roi: np.ndarray | None = None
        self.fixed_yaw: float | None = None
        self.yaw_rate_max = math.radians(90.0)
        self.cond_until = 0.0
        self.cond_dist = 0.0
        self.delay_until = 0.0
        self.takeoff_z = 0.0
        self.land_stage = ""
        self.circle: dict | None = None
        self.paused = False

    # ----- mode entry / exit ----------------------------------------------------------
    def init(self, ignore_checks: bool) -> bool:
        """Entering AUTO; False (with ArduPilot's text) when it must be refused.
        ignore_checks (disarmed): a copter enters without a mission (ModeAuto::init); a
        rover never does (Rover's ModeAuto::_enter checks the mission whatever the arming)."""
        ap = self.ap
        ap.refresh()
        if not self.runner.present() and not (self.copter and ignore_checks):
            if not self.copter:
                ap.text(SEV_NOTICE, "No Mission. Can't set AUTO.")
            return False
        if self.copter and ap.armed and ap.on_ground and not self.runner.starts_with_takeoff(self.restart()):
            ap.text(SEV_CRITICAL, "Auto: Missing Takeoff Cmd")
            return False
        self.sub = "loiter" if self.copter else "stop"
        self.roi = None
        self.fixed_yaw = None
        self.paused = False
        self.dest = None
        ap.speed.clear()                  # the waypoint controller starts at its default speeds
        if self.copter:
            ap.push_params({n: float(ap.params.get(n)) for n in ("WPNAV_SPEED_UP", "WPNAV_SPEED_DN")
                            if ap.params.get(n) is not None})
        self.waiting_to_start = True
        return True

    def exit(self) -> None:
        if self.runner.state == RUNNING:
            self.runner.stop()
        self.paused = False

    def mission_start(self) -> None:
        """MAV_CMD_MISSION_START after AUTO was entered: auto armed, mission running."""
        self.ap.auto_armed = True
        if not self.waiting_to_start and self.runner.state != RUNNING:
            self.runner.start_or_resume(self.restart())

    def restart(self) -> bool:
        return int(self.ap.params.get("MIS_RESTART", 0)) == 1

    # ----- the periodic step -----------------------------------------------------------
    def step(self) -> None:
        """Start once a position is known, restart the command on a new upload, walk."""
        ap = self.ap
        version = ap.missions.version[MISSION]
        if self.waiting_to_start:
            if ap.est_ok:
                self.runner.start_or_resume(self.restart())
                self.waiting_to_start = False
                self.seen_version = version
        else:
            if version != self.seen_version:
                self.seen_version = version
                if self.runner.state == RUNNING and self.sub == "wp":
                    if self.runner.restart_current_nav():
                        ap.text(SEV_CRITICAL, "Auto mission changed, restarted command")
                    else:
                        ap.text(SEV_CRITICAL, "Auto mission changed but failed to restart command")
            self.runner.update()

    # ----- end of mission ---------------------------------------------------------------
    def exit_mission(self) -> None:
        ap = self.ap
        if self.copter:
            if ap.on_ground:
                if ap.armed:
                    ap.disarm(force=True, reason="mission complete")
            else:
                ap.hold_here()
                self.sub = "loiter"
        else:
            ap.text(SEV_NOTICE, "Mission Complete")
            self.sub = "stop"

    def on_disarmed(self, in_auto: bool) -> None:
        """ArduCopter resets the mission (back to its first item) on every disarm; ArduRover
        only when disarmed outside AUTO (in AUTO the mission may be paused and resumed)."""
        if self.copter or not in_auto:
            self.runner.reset()

    # ----- DO_PAUSE_CONTINUE ------------------------------------------------------------
    def pause(self) -> bool:
        if self.sub != "wp" or self.reached_at is not None:
            return False
        self.paused = True
        self.ap.hold_here()
        return True

    def resume(self) -> bool:
        self.paused = False
        return True

    # ----- the mission protocol's calls ---------------------------------------------------
    def set_current(self, seq) -> bool:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: False if seq is not a valid item."""
        try:
            seq = int(seq)
        except (TypeError, ValueError, OverflowError):
            return False
        return self.runner.set_current(seq)

    def current(self) -> tuple[int, int]:
        """(seq, mission_state) for MISSION_CURRENT: the navigation command flown, and the
        runner's state (a paused leg is still ACTIVE, as ArduPilot reports it)."""
        return self.runner.current_seq(), self.runner.mission_state()


class MissionMode:
    """The hooks the copter's and the rover's AUTO modes share, put before their vehicle's
    Mode class: the mission is started, stepped (every tick, disarmed too, before the vehicle
    flies), paused and left through its AutoMission, which flies the RTL mode for
    NAV_RETURN_TO_LAUNCH."""

    mission_required = True

    def __init__(self, ap) -> None:
        super().__init__(ap)
        self.mission = AutoMission(ap, ap.flightmodes[ap.RTL])

    def init(self, ignore_checks: bool) -> bool:
        """AutoMission.init's checks (ignore_checks: disarmed)."""
        return self.mission.init(ignore_checks)

    def exit(self) -> None:
        super().exit()
        self.mission.exit()

    def pause(self) -> bool:
        return self.mission.pause()

    def resume(self) -> bool:
        return self.mission.resume()

    def run(self, dt: float) -> None:
        self.mission.step()
        self.mission_stepped()
        super().run(dt)

    def mission_stepped(self) -> None:
        """After the mission's step, before the vehicle flies: what the vehicle's AUTO does
        with the sub-mode the step left (nothing by default)."""
