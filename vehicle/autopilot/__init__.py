"""The autopilot: modes, arming and pre-arm checks, commands, GCS failsafe, parameters.

Pure logic over a batched fleet (vehicle/fleet.py); the MAVLink layer lives in vehicle/link/.

The names below are loaded when first used (PEP 562), so importing a light submodule
(vehicle.autopilot.mission_store, .params) does not load the autopilots and, through their
estimator, filterpy and scipy (most of `towerlink sitl`'s start-up time).
"""
from __future__ import annotations

__all__ = ["CopterAutopilot", "RoverAutopilot", "ParamStore"]


def __getattr__(name: str):
    if name == "CopterAutopilot":
        from vehicle.autopilot.copter import CopterAutopilot
        return CopterAutopilot
    if name == "RoverAutopilot":
        from vehicle.autopilot.rover import RoverAutopilot
        return RoverAutopilot
    if name == "ParamStore":
        from vehicle.autopilot.params import ParamStore
        return ParamStore
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
