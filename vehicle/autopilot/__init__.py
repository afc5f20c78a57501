"""The autopilot: modes, arming and pre-arm checks, commands, GCS failsafe, parameters.

Pure logic over a batched fleet (vehicle/fleet.py); the MAVLink layer lives in vehicle/link/.
The autopilots are vehicle.autopilot.copter.CopterAutopilot and .rover.RoverAutopilot, the
parameters vehicle.autopilot.params.ParamStore. This package imports none of them, so a light
module (.mission_store, .params) loads without the autopilots and, through their estimator,
filterpy and scipy (most of `towerlink sitl`'s start-up time).
"""
