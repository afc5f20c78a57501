"""The shared foundation every room stands on: frames and transforms (``common.frames``),
the tf2_ros-style node API (``common.tf2_ros``), the MAVLink plumbing (``common.mavlink``:
the project dialect, signing, connection strings, mode numbers, the lockstep wire format),
scenarios and their loader, geodesy and the QGC WPL mission format.

It imports nothing from ``vehicle``, ``gcs``, ``bridge`` or ``tools``; they all import it.
"""
