"""Pure controllers (copter cascade, rover steering/speed, kinematic shaping)."""
