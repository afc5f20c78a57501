"""MAVLink endpoints (one asyncio loop for the whole world) and per-vehicle message handling.

The names below are loaded when first used (PEP 562): `parse_endpoint` (the command line's
check of an endpoint) must not load the vehicle link and, through it, the autopilots.
"""
from __future__ import annotations

__all__ = ["VehicleLink", "make_endpoint", "parse_endpoint"]


def __getattr__(name: str):
    if name == "VehicleLink":
        from vehicle.link.vehicle_link import VehicleLink
        return VehicleLink
    if name == "make_endpoint":
        from vehicle.link.endpoints import make_endpoint
        return make_endpoint
    if name == "parse_endpoint":
        from vehicle.link.endpoints import parse_endpoint
        return parse_endpoint
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
