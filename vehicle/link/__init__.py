"""MAVLink endpoints (one asyncio loop for the whole world) and per-vehicle message handling."""
from vehicle.link.endpoints import make_endpoint, parse_endpoint
from vehicle.link.vehicle_link import VehicleLink

__all__ = ["VehicleLink", "make_endpoint", "parse_endpoint"]
