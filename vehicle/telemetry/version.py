"""The firmware a towerlink vehicle says it runs: ArduPilot's version numbers, the banner
of MAV_CMD_DO_SEND_BANNER and AUTOPILOT_VERSION's flight_custom_version.

towerlink speaks ArduCopter / ArduRover 4.5 (FLIGHT_SW_VERSION), so ground stations pick
their 4.5 behaviour. Where ArduPilot puts its build's git hash (8 hex characters: the
"(2a3dc4b7)" of the banner, the ASCII bytes of flight_custom_version) towerlink puts
`build_hash()`: a wheel carries no git history, so the hash is the first 8 hex digits of
SHA-1("towerlink <package version>") -- the same for every install of one release,
different for the next, and not a commit id.
"""
from __future__ import annotations

import functools
import hashlib
from importlib import metadata

from pymavlink.dialects.v20 import ardupilotmega as mav

VERSION = (4, 5, 0)
FLIGHT_SW_VERSION = (VERSION[0] << 24) | (VERSION[1] << 16) | (VERSION[2] << 8) | mav.FIRMWARE_VERSION_TYPE_OFFICIAL
FIRMWARE = {"copter": "ArduCopter", "rover": "ArduRover"}
# AP_Motors' frame and type strings for the one frame towerlink simulates
COPTER_FRAME = "Frame: QUAD/X"


@functools.cache
def package_version() -> str:
    """towerlink's package version ("0+unknown" when it is not installed)."""
    try:
        return metadata.version("towerlink")
    except metadata.PackageNotFoundError:
        return "0+unknown"


@functools.cache
def build_hash() -> str:
    """8 lowercase hex characters standing where ArduPilot has its git hash (module doc)."""
    return hashlib.sha1(f"towerlink {package_version()}".encode()).hexdigest()[:8]


def fw_string(kind: str) -> str:
    """ArduPilot's fw_string: "ArduCopter V4.5.0 (<hash>)"."""
    major, minor, patch = VERSION
    return f"{FIRMWARE.get(kind, 'ArduCopter')} V{major}.{minor}.{patch} ({build_hash()})"


def system_id(sysid: int) -> str:
    """The board's system id line: SITL prints its host's id; towerlink names the vehicle."""
    return f"towerlink SITL {sysid}"


def banner(kind: str, sysid: int) -> list[str]:
    """The STATUSTEXTs (severity INFO) of MAV_CMD_DO_SEND_BANNER, in ArduPilot's order:
    firmware and version, the system id, then (Copter) the frame. SITL has no OS or IO
    co-processor line."""
    lines = [fw_string(kind), system_id(sysid)]
    if kind == "copter":
        lines.append(COPTER_FRAME)
    return lines


def custom_version_bytes() -> list[int]:
    """AUTOPILOT_VERSION.flight_custom_version: the hash's 8 ASCII characters as bytes (no NUL)."""
    return list(build_hash().encode("ascii"))
