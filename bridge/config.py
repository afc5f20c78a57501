"""What the bridge is told (BridgeConfig) and what it keeps per vehicle (VehicleRecord)."""
from __future__ import annotations

from dataclasses import dataclass, field

from common.mavlink.ids import TOWER_SYSID
from bridge.links import Link
from bridge.pairing import VehicleFrames
from bridge.timeline import TimesyncProbe


@dataclass
class BridgeConfig:
    tower: str = "udpin:127.0.0.1:14600"
    drone: str | None = "udpout:127.0.0.1:14560"
    rover: str | None = "udpout:127.0.0.1:14570"
    outs: list = field(default_factory=list)
    drone_sysid: int = 1
    rover_sysid: int = 2
    sysid: int = 250
    compid: int = 191           # MAV_COMP_ID_ONBOARD_COMPUTER
    tower_frame: str = "tower"
    world_frame: str = "world"
    world_origin: tuple | None = None   # (lat, lon, alt AMSL) of world; None: the drone's EKF origin
    statics: list = field(default_factory=list)   # TransformStamped
    follow: bool = True
    follow_frame: str = "drone_yaw"
    follow_offset: tuple = (0.0, 0.0)
    follow_rate: float = 10.0
    follow_timeout: float = 1.0
    follow_ff: bool = True
    speedup: float = 1.0
    telemetry_rate: float = 20.0
    tf_rate: float = 20.0
    cache_time: float = 10.0
    max_transform_age: float = 0.5
    time_grace: float = 1.5     # wall s to wait for a vehicle's SYSTEM_TIME before presuming one world
    quiet: bool = False
    # trust: who may add static frames over the wire, and signing on the tower link
    trust_sysids: tuple = (TOWER_SYSID,)
    allow_redefine: bool = False    # may a trusted sender redefine a scenario frame?
    signing_key: bytes | None = None
    # with signing_key: the vehicle links too take only packets signed with it (else the bridge
    # trusts them, and re-signs what it translates from them for the tower)
    vehicle_signing: bool = False
    # a family: every vehicle as (name, url, sysid), and (drone, rover) sysid pairs to
    # follow; empty: the lab's drone and rover above
    vehicles: list = field(default_factory=list)
    pairs: list = field(default_factory=list)
    # nodes: a world-frame link for tf2_ros-style nodes, and routing only
    nodes: str | None = None        # e.g. udpin:127.0.0.1:14620 (common.tf2_ros.DEFAULT_URL's peer)
    route_only: bool = False        # no vehicle frames, no goal translation, no follow: nodes do them
    lockstep: bool = False      # a participant of the world's lockstep (bridge.lockstep_desk)
    lockstep_nodes: int = 0     # with lockstep and nodes: how many nodes to wait for (bridge.node_lockstep)


@dataclass
class VehicleRecord:
    """The bridge's record of one vehicle it serves (not the simulated `vehicle` package)."""
    name: str
    sysid: int
    link: Link
    frames: VehicleFrames
    custom_mode: int | None = None
    armed: bool = False
    last_heartbeat_wall: float | None = None
    last_att_wall: float = -1e9
    last_pos_wall: float = -1e9
    last_stream_req: float = -1e9
    position: tuple | None = None       # latest world (x, y, z), m NED
    probe: TimesyncProbe = field(default_factory=TimesyncProbe)
    last_rtt_log: float = -1e9
    offset_logged: bool = False
    last_time_req: float = -1e9
