"""One parameter's definition: ArduPilot name, default, range, type and units (pure data).

The tables that list them are params.py (the autopilot's own) and params_ardupilot.py (the
ones ground stations read by default); both build ParamDefs from here.
"""
from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mav


@dataclass(frozen=True)
class ParamDef:
    name: str
    default: float
    lo: float
    hi: float
    integer: bool = False
    doc: str = ""
    units: str = ""                 # ArduPilot's @Units
    ptype: int | None = None        # ArduPilot's MAV_PARAM_TYPE (AP_Int8/16/32, AP_Float)

    @property
    def mav_type(self) -> int:
        if self.ptype is not None:
            return self.ptype
        return mav.MAV_PARAM_TYPE_INT32 if self.integer else mav.MAV_PARAM_TYPE_REAL32
