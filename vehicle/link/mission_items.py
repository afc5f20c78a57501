"""Per-item checks of the mission protocol, with ArduPilot's rules and limits (pure).

An uploaded item is checked as ArduPilot's AP_Mission (MISSION), AC_PolyFence (FENCE) and
AP_Rally (RALLY) check it, and refused with the same MAV_MISSION_RESULT:

- MISSION: the command must be one ArduPilot stores (else UNSUPPORTED; commands 0 and 1
  are INVALID); params 1..4 must be finite (NaN allowed only where ArduPilot allows it,
  param4 of NAV_WAYPOINT / NAV_LAND / NAV_TAKEOFF) else INVALID_PARAMn; for commands that
  carry a location: lat within +-90 deg (INVALID_PARAM5_X), lon within +-180 deg
  (INVALID_PARAM6_Y), z finite and below 83 km (INVALID_PARAM7), frame GLOBAL /
  GLOBAL_RELATIVE_ALT / their _INT forms / MISSION (else UNSUPPORTED_FRAME: ArduPilot
  refuses local frames for mission items, and terrain frames need terrain data, which the
  SITL does not have).
- FENCE: frame GLOBAL* (incl. terrain, as ArduPilot), command one of the five fence items;
  then the whole list is validated at the end (polygon vertex runs, positive circle radii,
  at most one return point, lat/lon in range) with ArduPilot's STATUSTEXT.
- RALLY: NAV_RALLY_POINT in GLOBAL_RELATIVE_ALT(_INT), lat/lon in range, z an int16.

Coordinates: x / y are degE7 (MISSION_ITEM_INT); a legacy MISSION_ITEM's float degrees are
converted with `from_legacy`.
"""
from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.mission_store import FENCE, MISSION, RALLY, MissionItem

R = mav  # MAV_MISSION_* results

# how many items each list holds (ArduPilot: a Pixhawk's 15-byte-per-item mission storage holds
# 724 items; fence and rally counts are uint8 in ArduPilot's storage)
MAX_ITEMS = {MISSION: 724, FENCE: 255, RALLY: 255}
LOCATION_ALT_MAX_M = 83000.0      # ArduPilot's Location altitude limit (24-bit cm)

# commands whose x/y/z are a location (ArduPilot's AP_Mission::stored_in_location)
LOCATION_COMMANDS = frozenset({
    mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_CMD_NAV_LOITER_UNLIM, mav.MAV_CMD_NAV_LOITER_TURNS,
    mav.MAV_CMD_NAV_LOITER_TIME, mav.MAV_CMD_NAV_LAND, mav.MAV_CMD_NAV_TAKEOFF,
    mav.MAV_CMD_NAV_CONTINUE_AND_CHANGE_ALT, mav.MAV_CMD_NAV_LOITER_TO_ALT,
    mav.MAV_CMD_NAV_SPLINE_WAYPOINT, mav.MAV_CMD_NAV_GUIDED_ENABLE, mav.MAV_CMD_DO_SET_HOME,
    mav.MAV_CMD_DO_LAND_START, mav.MAV_CMD_DO_GO_AROUND, mav.MAV_CMD_DO_SET_ROI,
    mav.MAV_CMD_DO_SET_ROI_LOCATION, mav.MAV_CMD_NAV_VTOL_TAKEOFF, mav.MAV_CMD_NAV_VTOL_LAND,
    mav.MAV_CMD_NAV_PAYLOAD_PLACE,
})
# every command ArduPilot's mission storage accepts (AP_Mission::mavlink_int_to_mission_cmd)
MISSION_COMMANDS = LOCATION_COMMANDS | frozenset({
    mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, mav.MAV_CMD_NAV_DELAY, mav.MAV_CMD_NAV_ALTITUDE_WAIT,
    mav.MAV_CMD_NAV_SET_YAW_SPEED, mav.MAV_CMD_NAV_ATTITUDE_TIME, mav.MAV_CMD_NAV_SCRIPT_TIME,
    mav.MAV_CMD_CONDITION_DELAY, mav.MAV_CMD_CONDITION_DISTANCE, mav.MAV_CMD_CONDITION_YAW,
    mav.MAV_CMD_DO_JUMP, mav.MAV_CMD_DO_CHANGE_SPEED, mav.MAV_CMD_DO_SET_RELAY,
    mav.MAV_CMD_DO_REPEAT_RELAY, mav.MAV_CMD_DO_SET_SERVO, mav.MAV_CMD_DO_REPEAT_SERVO,
    mav.MAV_CMD_DO_SET_ROI_NONE, mav.MAV_CMD_DO_DIGICAM_CONFIGURE, mav.MAV_CMD_DO_DIGICAM_CONTROL,
    mav.MAV_CMD_DO_MOUNT_CONTROL, mav.MAV_CMD_DO_SET_CAM_TRIGG_DIST, mav.MAV_CMD_DO_FENCE_ENABLE,
    mav.MAV_CMD_DO_AUX_FUNCTION, mav.MAV_CMD_DO_PARACHUTE, mav.MAV_CMD_DO_INVERTED_FLIGHT,
    mav.MAV_CMD_DO_GRIPPER, mav.MAV_CMD_DO_GUIDED_LIMITS, mav.MAV_CMD_DO_AUTOTUNE_ENABLE,
    mav.MAV_CMD_DO_VTOL_TRANSITION, mav.MAV_CMD_DO_SET_REVERSE, mav.MAV_CMD_DO_ENGINE_CONTROL,
    mav.MAV_CMD_DO_WINCH, mav.MAV_CMD_DO_SET_RESUME_REPEAT_DIST, mav.MAV_CMD_DO_SPRAYER,
    mav.MAV_CMD_DO_SEND_SCRIPT_MESSAGE, mav.MAV_CMD_DO_PAUSE_CONTINUE,
    mav.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
})
# NaN is "unset" for param4 (yaw) of these (ArduPilot's sanity_check_params)
NAN_PARAM4_OK = frozenset({mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_CMD_NAV_LAND, mav.MAV_CMD_NAV_TAKEOFF,
                           mav.MAV_CMD_NAV_VTOL_TAKEOFF, mav.MAV_CMD_NAV_VTOL_LAND})
# x / y are not a location for these, in MISSION_ITEM as well (no 1e7 scaling)
XY_NOT_LATLON = frozenset({mav.MAV_CMD_DO_DIGICAM_CONTROL, mav.MAV_CMD_DO_DIGICAM_CONFIGURE,
                           mav.MAV_CMD_NAV_ATTITUDE_TIME, mav.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW})

MISSION_FRAMES = frozenset({mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_FRAME_MISSION,
                            mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
FENCE_FRAMES = frozenset({mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                          mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                          mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
RALLY_FRAMES = frozenset({mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})

POLY_INCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
POLY_EXCLUSION = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
CIRCLE_INCLUSION = mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
CIRCLE_EXCLUSION = mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
RETURN_POINT = mav.MAV_CMD_NAV_FENCE_RETURN_POINT
FENCE_COMMANDS = frozenset({POLY_INCLUSION, POLY_EXCLUSION, CIRCLE_INCLUSION, CIRCLE_EXCLUSION, RETURN_POINT})

_PARAM_ERRORS = (R.MAV_MISSION_INVALID_PARAM1, R.MAV_MISSION_INVALID_PARAM2,
                 R.MAV_MISSION_INVALID_PARAM3, R.MAV_MISSION_INVALID_PARAM4)


def lat_ok(x_e7: float) -> bool:
    """Latitude in degE7 within +-90 deg (False for NaN)."""
    return abs(x_e7) <= 900_000_000


def lon_ok(y_e7: float) -> bool:
    """Longitude in degE7 within +-180 deg (False for NaN)."""
    return abs(y_e7) <= 1_800_000_000


def check_params(item: MissionItem) -> int:
    """INVALID_PARAM1..4 for a NaN (where not allowed) or infinite param, else ACCEPTED."""
    for k, v in enumerate(item.params):
        if math.isinf(v) or (math.isnan(v) and not (k == 3 and item.command in NAN_PARAM4_OK)):
            return _PARAM_ERRORS[k]
    return R.MAV_MISSION_ACCEPTED


def check_mission_item(item: MissionItem) -> int:
    """One MISSION item, as ArduPilot's AP_Mission converts it for storage."""
    bad = check_params(item)
    if bad != R.MAV_MISSION_ACCEPTED:
        return bad
    if item.command in (0, 1):
        return R.MAV_MISSION_INVALID
    if item.command not in MISSION_COMMANDS:
        return R.MAV_MISSION_UNSUPPORTED
    if item.command in LOCATION_COMMANDS:
        if not lat_ok(item.x):
            return R.MAV_MISSION_INVALID_PARAM5_X
        if not lon_ok(item.y):
            return R.MAV_MISSION_INVALID_PARAM6_Y
        if not math.isfinite(item.z) or abs(item.z) >= LOCATION_ALT_MAX_M:
            return R.MAV_MISSION_INVALID_PARAM7
        if item.frame not in MISSION_FRAMES:
            return R.MAV_MISSION_UNSUPPORTED_FRAME
    return R.MAV_MISSION_ACCEPTED


def check_fence_item(item: MissionItem) -> int:
    """One FENCE item (ArduPilot checks frame, then command; the list is validated at the end)."""
    if item.frame not in FENCE_FRAMES:
        return R.MAV_MISSION_UNSUPPORTED_FRAME
    if item.command not in FENCE_COMMANDS:
        return R.MAV_MISSION_UNSUPPORTED
    if not math.isfinite(item.param1):
        return R.MAV_MISSION_INVALID_PARAM1
    return R.MAV_MISSION_ACCEPTED


def check_rally_item(item: MissionItem) -> int:
    """One RALLY point (ArduPilot's AP_Rally: alt stored as int16 metres)."""
    if item.command != mav.MAV_CMD_NAV_RALLY_POINT:
        return R.MAV_MISSION_UNSUPPORTED
    if item.frame not in RALLY_FRAMES:
        return R.MAV_MISSION_UNSUPPORTED_FRAME
    if not lat_ok(item.x):
        return R.MAV_MISSION_INVALID_PARAM5_X
    if not lon_ok(item.y):
        return R.MAV_MISSION_INVALID_PARAM6_Y
    if not (math.isfinite(item.z) and -32768 <= item.z <= 32767):
        return R.MAV_MISSION_INVALID_PARAM7
    return R.MAV_MISSION_ACCEPTED


CHECKS = {MISSION: check_mission_item, FENCE: check_fence_item, RALLY: check_rally_item}


def validate_fence(items: list[MissionItem]) -> str | None:
    """None if the fence list is valid, else ArduPilot's STATUSTEXT for the first problem.

    Polygon vertices come in runs of param1 (the vertex count, >= 3) items of one type;
    circles need a positive radius (param1); at most one return point.
    """
    expecting = None
    left = 0
    total = 0
    seen_return = False
    for it in items:
        if it.command in (POLY_INCLUSION, POLY_EXCLUSION):
            n = it.param1
            if n < 3:
                return f"Invalid vertex count ({int(n)})"
            if left == 0:
                left, total, expecting = int(n), int(n), it.command
            elif it.command != expecting:
                return f"Received incorrect vertex type (want={expecting} got={it.command})"
            elif int(n) != total:
                return f"Unexpected vertex count want={total} got={int(n)}"
            left -= 1
        elif it.command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION):
            if left:
                return f"Received incorrect type (want={expecting} got={it.command})"
            if not it.param1 > 0:
                return "Non-positive circle radius"
        elif it.command == RETURN_POINT:
            if left:
                return f"Received incorrect type (want={expecting} got={it.command})"
            if seen_return:
                return "Multiple return points"
            seen_return = True
        if not (lat_ok(it.x) and lon_ok(it.y)):
            return "Bad lat or lon"
    if left:
        return "Incorrect item count"
    return None


def _to_int(v: float) -> int:
    """degrees -> degE7, for a value already checked to be in range."""
    return int(round(v * 1e7))


def from_legacy(m, mission_type: int) -> tuple[int, MissionItem | None]:
    """A MISSION_ITEM (float x/y in degrees) as a stored item, or the result refusing it."""
    x, y = float(m.x), float(m.y)
    if m.command in XY_NOT_LATLON:
        # raw values stored in MISSION_ITEM_INT's int32 x / y: refuse what does not fit
        if not (math.isfinite(x) and -2**31 <= x < 2**31):
            return R.MAV_MISSION_INVALID_PARAM5_X, None
        if not (math.isfinite(y) and -2**31 <= y < 2**31):
            return R.MAV_MISSION_INVALID_PARAM6_Y, None
        xi, yi = int(x), int(y)
    else:
        if not abs(x) <= 90.0:
            return R.MAV_MISSION_INVALID_PARAM5_X, None
        if not abs(y) <= 180.0:
            return R.MAV_MISSION_INVALID_PARAM6_Y, None
        xi, yi = _to_int(x), _to_int(y)
    return R.MAV_MISSION_ACCEPTED, MissionItem(
        seq=int(m.seq), frame=int(m.frame), command=int(m.command), current=int(m.current),
        autocontinue=int(m.autocontinue), param1=float(m.param1), param2=float(m.param2),
        param3=float(m.param3), param4=float(m.param4), x=xi, y=yi, z=float(m.z),
        mission_type=mission_type)


def from_int(m, mission_type: int) -> MissionItem:
    """A MISSION_ITEM_INT as a stored item (exactly the fields sent)."""
    return MissionItem(
        seq=int(m.seq), frame=int(m.frame), command=int(m.command), current=int(m.current),
        autocontinue=int(m.autocontinue), param1=float(m.param1), param2=float(m.param2),
        param3=float(m.param3), param4=float(m.param4), x=int(m.x), y=int(m.y), z=float(m.z),
        mission_type=mission_type)


def legacy_xy(item: MissionItem) -> tuple[float, float]:
    """x / y for a MISSION_ITEM reply: degrees for a location, raw for the few commands that are not."""
    if item.command in XY_NOT_LATLON:
        return float(item.x), float(item.y)
    return item.x * 1e-7, item.y * 1e-7


def from_wpl(w, mission_type: int = MISSION) -> tuple[int, MissionItem | None]:
    """A QGC WPL line (common.wpl.WplItem, degrees) as a stored item, checked as an upload would
    be: (ACCEPTED, item) or (the MAV_MISSION_RESULT refusing it, None)."""
    result, item = from_legacy(w, mission_type)
    if item is None:
        return result, None
    result = CHECKS[mission_type](item)
    return (result, item) if result == R.MAV_MISSION_ACCEPTED else (result, None)
