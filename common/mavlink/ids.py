"""MAVLink system ids every room agrees on."""
from __future__ import annotations

#: The tower GCS's system id: gcs.client's default source_system, the sysid a bridge trusts
#: by default (``--trust-sysid``), and 255 as in MAVProxy and QGroundControl.
TOWER_SYSID = 255
