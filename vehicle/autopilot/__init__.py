"""The autopilot: modes, arming and pre-arm checks, commands, GCS failsafe, parameters.

Pure logic over a batched fleet (vehicle/fleet.py); the MAVLink layer lives in vehicle/link/.
"""
from vehicle.autopilot.copter import CopterAutopilot
from vehicle.autopilot.params import ParamStore
from vehicle.autopilot.rover import RoverAutopilot

__all__ = ["CopterAutopilot", "RoverAutopilot", "ParamStore"]
