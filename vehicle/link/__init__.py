"""MAVLink endpoints (one asyncio loop for the whole world) and per-vehicle message handling.

The link is vehicle.link.vehicle_link.VehicleLink; the endpoints vehicle.link.endpoints
(make_endpoint, parse_endpoint). This package imports neither, so the command line's check of
an endpoint does not load the vehicle link and, through it, the autopilots.
"""
