"""What a vehicle reports beyond its core state: one module per message family, each a
pure reading of the simulation (sensors, estimator, controllers, fence) when a stream or a
request asks for the message, and the stream groups that schedule them (stream_groups.py).
The link's Telemetry (vehicle/link/telemetry.py) frames them."""
