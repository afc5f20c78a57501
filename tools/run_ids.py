"""A lab run's fixed ids and the drone parameters its scoring needs, light to import: the
`towerlink fly` launcher needs them before it starts the world, and tools.run_data and
tools.run_figures (which load numpy) are only needed once the run is over."""
from __future__ import annotations

#: the lab's system ids: `towerlink sitl`'s vehicle 0 (the drone) and 1 (the rover)
DRONE, ROVER = 1, 2

# ArduPilot Copter defaults, used when the tlog holds no PARAM_VALUE for them.
PARAM_DEFAULTS = {"WPNAV_SPEED": 500.0, "WPNAV_ACCEL": 250.0, "PSC_JERK_XY": 5.0}
#: the drone's parameters the minimum times need (asked of it while a run flies)
SCORING_PARAMS = tuple(PARAM_DEFAULTS)
