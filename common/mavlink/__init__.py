"""MAVLink plumbing shared by the vehicle, the bridge and the ground station: the towerlink
dialect, MAVLink 2 signing, pymavlink connection strings, ArduPilot mode numbers, peers and
the lockstep wire format."""
