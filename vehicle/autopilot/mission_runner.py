"""The mission walker: which stored item runs now, as ArduPilot's AP_Mission decides it (pure).

No geometry, sockets or clocks here: the flight mode that owns a MissionRunner (auto.py)
starts and verifies each command through two callbacks, and this module only decides
the order. Facts from ArduPilot's AP_Mission (learned from its source, re-expressed):

- Item 0 is home; a mission is "present" only with more than one item. Walking starts
  at item 1.
- Two slots run side by side: one navigation command (ids up to MAV_CMD_NAV_LAST = 95,
  plus NAV_SET_YAW_SPEED) and one do/condition command. When a navigation command is
  verified complete, the next navigation command is loaded at once; the do/condition
  commands that sit between two navigation commands run one after another while the
  navigation command flies (a CONDITION_* holds back the do commands after it, never
  the navigation). A navigation command whose start fails is skipped.
- Every command started says "Mission: <seq> <name>" (STATUSTEXT, INFO), name as
  AP_Mission spells it (WP, Takeoff, Land, RTL, LoitUnlim, CondDelay, ...).
- DO_JUMP (param1 target seq, param2 repeat count, -1 = forever) is never started: it is
  resolved while looking for the next command. Each time a counted jump is taken while
  advancing the navigation command, "Mission: <seq> Jump <n>/<total>" is said; a jump
  already taken its count of times falls through to the item after it. A jump to 0 or
  past the end ends the search (and so the mission). Counts reset when the mission starts
  again from the beginning.
- start(): from the first item, counts reset. stop(): state STOPPED (leaving AUTO).
  resume(): a COMPLETE mission starts again; a STOPPED one restarts the command it was
  flying (re-running its start, so the vehicle flies to that waypoint again). MIS_RESTART
  picks between them on entering AUTO (0 resume, 1 restart).
- set_current(seq): RUNNING -> the walker jumps there now; otherwise it remembers seq so
  the next resume starts there (state STOPPED), and seq 0 (or a COMPLETE mission) also
  resets the jump counts. Out of range, or no mission: refused.
- When no navigation command is left the mission is COMPLETE and the mode's
  `complete` callback runs (loiter, land, hold or disarm: the vehicle's choice).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import MissionItem

STOPPED, RUNNING, COMPLETE = 0, 1, 2
NONE = -1                     # no command loaded
JUMP_FOREVER = -1
MAX_JUMP_HOPS = 64            # AP_Mission gives up after this many jumps in one search
MAX_DO_LOOP = 255

NAMES = {
    mav.MAV_CMD_NAV_WAYPOINT: "WP", mav.MAV_CMD_NAV_SPLINE_WAYPOINT: "SplineWP",
    mav.MAV_CMD_NAV_RETURN_TO_LAUNCH: "RTL", mav.MAV_CMD_NAV_LOITER_UNLIM: "LoitUnlim",
    mav.MAV_CMD_NAV_LOITER_TIME: "LoitTime", mav.MAV_CMD_NAV_LOITER_TURNS: "LoitTurns",
    mav.MAV_CMD_NAV_GUIDED_ENABLE: "GuidedEnable", mav.MAV_CMD_NAV_LOITER_TO_ALT: "LoitAltitude",
    mav.MAV_CMD_NAV_SET_YAW_SPEED: "SetYawSpd", mav.MAV_CMD_CONDITION_DELAY: "CondDelay",
    mav.MAV_CMD_CONDITION_DISTANCE: "CondDist", mav.MAV_CMD_CONDITION_YAW: "CondYaw",
    mav.MAV_CMD_DO_CHANGE_SPEED: "ChangeSpeed", mav.MAV_CMD_DO_SET_HOME: "SetHome",
    mav.MAV_CMD_DO_SET_SERVO: "SetServo", mav.MAV_CMD_DO_SET_RELAY: "SetRelay",
    mav.MAV_CMD_DO_SET_ROI: "SetROI", mav.MAV_CMD_NAV_TAKEOFF: "Takeoff", mav.MAV_CMD_NAV_LAND: "Land",
    mav.MAV_CMD_NAV_DELAY: "Delay", mav.MAV_CMD_DO_LAND_START: "LandStart",
    mav.MAV_CMD_DO_FENCE_ENABLE: "FenceEnable", mav.MAV_CMD_DO_SET_REVERSE: "SetReverse",
}


def command_name(cmd: int) -> str:
    """AP_Mission's short name of a command, "?" when it has none."""
    return NAMES.get(cmd, "?")


def is_nav(cmd: int) -> bool:
    return cmd <= mav.MAV_CMD_NAV_LAST or cmd == mav.MAV_CMD_NAV_SET_YAW_SPEED


class MissionRunner:
    """Walks `items()` (index i = seq i; 0 is home) as AP_Mission does.

    start_cmd(item) -> bool: the mode begins the command (False: it cannot, skip it).
    verify_cmd(item) -> bool: the mode says the command is done (called every update).
    complete(): the mission has run out of navigation commands.
    text(severity, message): STATUSTEXT.
    """

    def __init__(self, items: Callable[[], Sequence[MissionItem]],
                 start_cmd: Callable[[MissionItem], bool],
                 verify_cmd: Callable[[MissionItem], bool],
                 complete: Callable[[], None],
                 text: Callable[[int, str], None]) -> None:
        self.items = items
        self.start_cmd = start_cmd
        self.verify_cmd = verify_cmd
        self.on_complete = complete
        self.text = text
        self.state = STOPPED
        self.nav: MissionItem | None = None
        self.nav_index = NONE
        self.nav_loaded = False
        self.do: MissionItem | None = None
        self.do_index = NONE
        self.do_loaded = False
        self.do_all_done = False
        self.jumps: dict[int, int] = {}       # DO_JUMP seq -> times taken

    # ----- queries ------------------------------------------------------------------
    def count(self) -> int:
        return len(self.items())

    def present(self) -> bool:
        return self.count() > 1

    def current_seq(self) -> int:
        """The navigation command being flown (what MISSION_CURRENT.seq reports)."""
        return max(self.nav_index, 0)

    def mission_state(self) -> int:
        """MISSION_STATE for MISSION_CURRENT, as ArduPilot's GCS_MAVLINK::mission_state maps it:
        no mission -> NO_MISSION, STOPPED -> NOT_STARTED (also part way, after leaving AUTO),
        RUNNING -> ACTIVE, COMPLETE -> COMPLETE. ArduPilot never reports PAUSED."""
        if not self.present():
            return mav.MISSION_STATE_NO_MISSION
        return {STOPPED: mav.MISSION_STATE_NOT_STARTED, RUNNING: mav.MISSION_STATE_ACTIVE,
                COMPLETE: mav.MISSION_STATE_COMPLETE}[self.state]

    def starts_with_takeoff(self, restart: bool) -> bool:
        """AP_Mission: the first navigation command flown next (from item 1 when restarting or
        never started, else the current one; up to 16 looked at, NAV_DELAY skipped) is a takeoff."""
        seq = 1 if restart or self.nav_index < 1 else self.nav_index
        for _ in range(16):
            item = self._next_cmd(seq, increment=False)
            while item is not None and not is_nav(item.command):
                item = self._next_cmd(item.seq + 1, increment=False)
            if item is None:
                return False
            if item.command == mav.MAV_CMD_NAV_TAKEOFF:
                return True
            if item.command != mav.MAV_CMD_NAV_DELAY:
                return False
            seq = item.seq + 1
        return False

    def _read(self, seq: int) -> MissionItem | None:
        lst = self.items()
        return lst[seq] if 0 < seq < len(lst) else None

    # ----- life cycle ---------------------------------------------------------------
    def reset(self) -> None:
        """Back to the first item with fresh jump counts (the state is kept)."""
        self.nav_loaded = self.do_loaded = self.do_all_done = False
        self.nav = self.do = None
        self.nav_index = self.do_index = NONE
        self.jumps.clear()

    def start(self) -> None:
        self.state = RUNNING
        self.reset()
        if not self._advance_nav():
            self._complete()

    def stop(self) -> None:
        self.state = STOPPED

    def resume(self) -> None:
        if self.state == COMPLETE:
            self.start()
            return
        if self.state == STOPPED:
            self.state = RUNNING
            if self.nav_index == NONE:
                self.start()
                return
        item = self._read(self.nav_index)
        if item is None:
            # the command we were flying is gone (a shorter mission): start from the top
            self.start()
            return
        self.nav = item
        if self.do_loaded and self.do_index != NONE:
            self.set_current(self.do_index)
        elif self.nav_loaded:
            self.set_current(self.nav_index)
        # no command loaded: stopped just after a nav command ended; update() finds the next

    def start_or_resume(self, restart: bool) -> None:
        """Entering AUTO: MIS_RESTART = 1 -> start, 0 -> resume."""
        if restart:
            self.start()
        else:
            self.resume()

    def restart_current_nav(self) -> bool:
        """Start the current navigation command again (the mission changed under it)."""
        if self.state != RUNNING or not 0 < self.nav_index < self.count():
            return False
        return self.set_current(self.nav_index)

    def set_current(self, seq: int) -> bool:
        """MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT; False if seq is not valid."""
        n = self.count()
        if seq < 0 or seq >= n or n <= 1:
            return False
        self.do_index, self.do_loaded, self.do_all_done = NONE, False, False
        self.nav_loaded = False
        if seq == 0 or self.state == COMPLETE:
            self.jumps.clear()
            seq = max(seq, 1)
        if self.state != RUNNING:
            # remember where a later resume begins: the first nav command at or after seq
            idx = seq
            while not self.nav_loaded:
                item = self._next_cmd(idx, increment=True)
                if item is None:
                    self.nav_index = NONE
                    return False
                if is_nav(item.command):
                    self.nav, self.nav_index, self.nav_loaded = item, item.seq, True
                elif not self.do_loaded:
                    self.do, self.do_index, self.do_loaded = item, item.seq, True
                idx = item.seq + 1
            if not self.do_loaded:
                self.do_all_done = True
            self.state = STOPPED
            return True
        if not self._advance_nav(seq):
            self._complete()
            return False
        return True

    # ----- the periodic step --------------------------------------------------------
    def update(self) -> None:
        if self.state != RUNNING or self.count() == 0:
            return
        if not self.nav_loaded or self.nav_index == NONE:
            if not self._advance_nav():
                self._complete()
                return
        elif self.verify_cmd(self.nav):
            self.nav_loaded = False
            if not self._advance_nav():
                self._complete()
                return
        if not self.do_loaded:
            self._advance_do()
        elif self.verify_cmd(self.do):
            self.do_loaded = False

    # ----- walking ------------------------------------------------------------------
    def _complete(self) -> None:
        self.state = COMPLETE
        self.on_complete()

    def _start(self, item: MissionItem) -> bool:
        self.text(mav.MAV_SEVERITY_INFO, f"Mission: {item.seq} {command_name(item.command)}")
        return bool(self.start_cmd(item))

    def _advance_nav(self, start_seq: int = 0) -> bool:
        """Load and start the next navigation command (from start_seq if given)."""
        if self.state != RUNNING or self.nav_loaded:
            return False
        self.do_index, self.do_loaded, self.do_all_done = NONE, False, False
        if start_seq > 0:
            idx = start_seq
        elif self.nav_index == NONE:
            idx = 1
        else:
            idx = self.nav_index + 1
        loops = MAX_DO_LOOP
        while not self.nav_loaded:
            # a jump loop whose commands all fail to start would never end: give up (AP_Mission)
            loops -= 1
            if loops < 0:
                return False
            item = self._next_cmd(idx, increment=True)
            if item is None:
                return False
            if is_nav(item.command):
                self.nav, self.nav_index = item, item.seq
                if self._start(item):
                    self.nav_loaded = True
            elif not self.do_loaded:
                self.do, self.do_index, self.do_loaded = item, item.seq, True
                self._start(item)
            idx = item.seq + 1
        if not self.do_loaded:
            self.do_all_done = True
        return True

    def _advance_do(self) -> None:
        if self.state != RUNNING or self.do_all_done:
            return
        idx = 1 if self.do_index == NONE else self.do_index + 1
        item = self._next_cmd(idx, increment=False) if idx < self.count() else None
        if item is None or is_nav(item.command):
            self.do_all_done = True
            return
        self.do, self.do_index, self.do_loaded = item, item.seq, True
        self._start(item)

    def _next_cmd(self, seq: int, increment: bool) -> MissionItem | None:
        """The first non-jump command at or after seq, following DO_JUMPs."""
        lst = self.items()
        n = len(lst)
        first_jump = NONE
        hops = MAX_JUMP_HOPS
        while 0 < seq < n:
            item = lst[seq]
            if item.command != mav.MAV_CMD_DO_JUMP:
                return item
            hops -= 1
            if hops <= 0:
                return None
            target, repeat = _jump_args(item)
            if target is None or target <= 0 or target >= n:
                return None
            if not increment and first_jump == seq:
                return None              # looped back to the same jump: it would never end
            if first_jump == NONE:
                first_jump = seq
            if repeat == JUMP_FOREVER:
                seq = target
                continue
            done = self.jumps.get(item.seq, 0)
            if done < repeat:
                if increment:
                    self.jumps[item.seq] = done + 1
                    self.text(mav.MAV_SEVERITY_INFO, f"Mission: {item.seq} Jump {done + 1}/{repeat}")
                seq = target
            else:
                seq += 1
        return None


def _jump_args(item: MissionItem) -> tuple[int | None, int]:
    """DO_JUMP (target seq, repeat count); (None, 0) when param1 is not a usable number."""
    try:
        target = int(item.param1)
        repeat = int(item.param2)
    except (ValueError, OverflowError):    # NaN / inf from a bad upload
        return None, 0
    return target, (JUMP_FOREVER if repeat < 0 else repeat)
