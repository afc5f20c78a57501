"""pymavlink for gcs.client, loaded as MAVLink 2 (MAVLINK20 must be set before mavutil loads)."""
from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

mavlink = mavutil.mavlink

__all__ = ["mavlink", "mavutil"]
