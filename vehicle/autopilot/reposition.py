"""MAV_CMD_DO_REPOSITION decoding as ArduPilot's handle_command_int_do_reposition (pure).

COMMAND_INT: x, y = latitude, longitude * 1e7, z (param7) = altitude in `frame`.
COMMAND_LONG: param5/param6 = latitude/longitude in degrees, param7 = altitude; ArduPilot
turns a COMMAND_LONG into a COMMAND_INT, and we read its altitude as MAV_FRAME_GLOBAL (AMSL).
param2 bit 0 (MAV_DO_REPOSITION_FLAGS_CHANGE_MODE) lets the command switch to GUIDED; without
it the vehicle must already be in GUIDED (else DENIED). A bad latitude/longitude, (0, 0), an
altitude that is not a number, a relative altitude of 0 (ArduPilot's Location::sanitize reads it
as "current altitude" and refuses) or a frame without altitude meaning -> DENIED.
What each vehicle does with param1 (speed) and param4 (yaw) is its own: ArduCopter ignores
both (set_destination without yaw), ArduRover takes a positive param1 as its GUIDED speed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mav

CHANGE_MODE = mav.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
AMSL_FRAMES = {mav.MAV_FRAME_GLOBAL, mav.MAV_FRAME_GLOBAL_INT}
REL_FRAMES = {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}


class RepositionDenied(ValueError):
    """The command's parameters are refused (MAV_RESULT_DENIED); str() says why."""


@dataclass(frozen=True)
class Reposition:
    change_mode: bool
    lat: float            # deg
    lon: float            # deg
    alt_amsl: float       # m
    speed: float | None   # m/s when param1 > 0, else None


def decode(p, frame: int | None, x: int | None, y: int | None, home_alt_amsl: float,
           in_guided: bool) -> Reposition:
    """DO_REPOSITION params -> Reposition; raises RepositionDenied."""
    flags = p[1] if math.isfinite(p[1]) and 0 <= p[1] < 2**31 else 0.0
    change_mode = bool(int(flags) & CHANGE_MODE)
    if not in_guided and not change_mode:
        raise RepositionDenied("not in GUIDED and no CHANGE_MODE flag")
    if x is None or y is None:                   # COMMAND_LONG
        if not (math.isfinite(p[4]) and math.isfinite(p[5])):
            raise RepositionDenied("latitude/longitude not numbers")
        lat, lon, frame = p[4], p[5], mav.MAV_FRAME_GLOBAL
    else:
        lat, lon = x * 1e-7, y * 1e-7
    if abs(lat) > 90 or abs(lon) > 180:
        raise RepositionDenied("latitude/longitude out of range")
    if lat == 0 and lon == 0:
        raise RepositionDenied("latitude/longitude 0, 0")
    alt = p[6]
    if not math.isfinite(alt) or abs(alt) > 83_000:  # LOCATION_ALT_MAX_M
        raise RepositionDenied("bad altitude")
    if frame in AMSL_FRAMES:
        amsl = alt
    elif frame in REL_FRAMES:
        if alt == 0:
            raise RepositionDenied("relative altitude 0")
        amsl = alt + home_alt_amsl
    else:
        raise RepositionDenied(f"frame {frame} not supported")
    speed = float(p[0]) if math.isfinite(p[0]) and p[0] > 0 else None
    return Reposition(change_mode, float(lat), float(lon), float(amsl), speed)
