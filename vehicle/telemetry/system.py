"""The board and the fence: POWER_STATUS, MEMINFO and FENCE_STATUS.

- POWER_STATUS: the simulated board's 5.0 V supply with a valid power brick; it has no
  servo-rail sensor (Vservo 0).
- MEMINFO: the free memory ArduPilot's SITL HAL reports (128 KiB; freemem is capped at 65535).
- FENCE_STATUS (GCS_MAVLINK::send_fence_status): only while FENCE_ENABLE is on. breach_status
  1 while any fence is breached; breach_count AC_Fence's count of new breaches; breach_type
  the last of MINALT, MAXALT, BOUNDARY (circle or polygon) that is breached; breach_time the
  time_boot_ms when a breach began from none; breach_mitigation NONE (towerlink has no
  avoidance that could limit the velocity).
"""
from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.autopilot.fence import ALT_MAX, ALT_MIN, CIRCLE, POLYGON
from vehicle.telemetry.wire import boot_ms

BOARD_VCC_MV = 5000
SITL_FREE_MEMORY = 0x20000


def breach_type(breaches: int) -> int:
    """FENCE_BREACH of a fence mask: later checks win, as ArduPilot's send_fence_status."""
    kind = mav.FENCE_BREACH_NONE
    if breaches & ALT_MIN:
        kind = mav.FENCE_BREACH_MINALT
    if breaches & ALT_MAX:
        kind = mav.FENCE_BREACH_MAXALT
    if breaches & (CIRCLE | POLYGON):
        kind = mav.FENCE_BREACH_BOUNDARY
    return kind


class SystemTelemetry:
    """POWER_STATUS, MEMINFO and FENCE_STATUS of one vehicle."""

    def __init__(self, ap) -> None:
        self.ap = ap

    def power_status_fields(self) -> tuple:
        return (BOARD_VCC_MV, 0, mav.MAV_POWER_STATUS_BRICK_VALID)

    def meminfo_fields(self) -> tuple:
        return (0, min(SITL_FREE_MEMORY, 0xFFFF), SITL_FREE_MEMORY)

    def fence_status_fields(self) -> tuple | None:
        fence = self.ap.fence
        if not fence.enabled():
            return None
        b = fence.breaches
        return (1 if b else 0, min(fence.breach_count, 0xFFFF), breach_type(b), boot_ms(fence.breach_time),
                mav.FENCE_MITIGATE_NONE)
