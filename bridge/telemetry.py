"""Vehicle telemetry into the bridge: clocks, pairing, the frame tree and the follower.

One vehicle message, one hop each (the loop decoded it and still routes it):

* LOCAL_POSITION_NED / ATTITUDE_QUATERNION: the boot-clock reading to the clock desk,
  the sample to pairing; each paired sample goes onto the one timeline (or is held back),
  into the frame tree, onto the transform stream, and, for the drone, to the follower;
* SYSTEM_TIME (compid 1) and TIMESYNC to the clock desk (our own probe's answer is not
  forwarded); HEARTBEAT (compid 1): mode and arming, and on first sight the telemetry
  streams (SET_MESSAGE_INTERVAL at --telemetry-rate) and SYSTEM_TIME are asked for.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from common.mavlink.dialect import towerlink as tl
from common.frames import TransformException
from common.tf2_ros.wire import transform_message
from bridge.clock_desk import ClockDesk
from bridge.config import BridgeConfig, VehicleRecord
from bridge.frame_tree import ORIGIN, FrameTree
from bridge.log import BridgeLog
from bridge.origins import OriginDesk, origin_from_message
from bridge.router import Router
from bridge.timeline import Timeline

MSG_HEARTBEAT = 0
MSG_SYSTEM_TIME = 2
MSG_ATTITUDE_QUATERNION = 31
MSG_LOCAL_POSITION_NED = 32
MSG_POSITION_TARGET_LOCAL_NED = 85
MSG_GPS_GLOBAL_ORIGIN = 49
MSG_TIMESYNC = 111
#: vehicle messages the bridge reads (besides routing them)
TELEMETRY_IN = frozenset((MSG_HEARTBEAT, MSG_SYSTEM_TIME, MSG_ATTITUDE_QUATERNION, MSG_LOCAL_POSITION_NED,
                          MSG_POSITION_TARGET_LOCAL_NED, MSG_TIMESYNC, MSG_GPS_GLOBAL_ORIGIN))
STREAM_REQUEST_PERIOD = 5.0     # wall s between re-asking a vehicle whose telemetry stopped


class TelemetryDesk:
    def __init__(self, cfg: BridgeConfig, vehicles: dict[int, VehicleRecord], clocks: ClockDesk,
                 timeline: Timeline, tree: FrameTree, origins: OriginDesk, followers: dict,
                 router: Router, log: BridgeLog, clock: Callable[[], float], wall: Callable[[], float]) -> None:
        self.cfg = cfg
        self.clock = clock                  # sim time (the lockstep barrier) with --lockstep, else wall
        self.wall = wall                    # the timeline's readings are always wall-stamped
        self.clocks, self.timeline, self.tree = clocks, timeline, tree
        self.followers = followers          # drone sysid -> (Follower, rover sysid)
        self.vehicles = vehicles
        self.origins = origins
        self.command, self.send_own_to_gcs, self.send_out = router.command, router.send_own_to_gcs, router.send_out
        self.log, self.warn_once = log.log, log.warn_once

    def on_message(self, v: VehicleRecord, mid: int, compid: int, msg) -> bool:
        """Take in a decoded vehicle message; False if it must not be forwarded."""
        now = self.clock()
        wall = self.wall()
        if mid == MSG_LOCAL_POSITION_NED:
            v.last_pos_wall = now
            v.position = self.world_position(v, (msg.x, msg.y, msg.z))
            self.clocks.reading(v, msg.time_boot_ms / 1000.0, wall)
            for s in v.frames.on_local_position(msg.time_boot_ms, msg.x, msg.y, msg.z,
                                                 msg.vx, msg.vy, msg.vz):
                self.on_frame_sample(v, s)
        elif mid == MSG_ATTITUDE_QUATERNION:
            v.last_att_wall = now
            self.clocks.reading(v, msg.time_boot_ms / 1000.0, wall)
            for s in v.frames.on_attitude_quaternion(msg.time_boot_ms, msg.q1, msg.q2, msg.q3, msg.q4):
                self.on_frame_sample(v, s)
        elif mid == MSG_SYSTEM_TIME and compid == 1:
            self.clocks.on_system_time(v, msg, wall)
            self.release_held()
        elif mid == MSG_TIMESYNC:
            return not self.clocks.on_timesync(v, msg, wall)
        elif mid == MSG_HEARTBEAT and compid == 1:
            self.on_heartbeat(v, msg, now)
        elif mid == MSG_GPS_GLOBAL_ORIGIN:
            self.on_origin(v, msg)
        return True

    # ------------------------------------------------------------------ origins
    def on_origin(self, v: VehicleRecord, msg) -> None:
        """GPS_GLOBAL_ORIGIN: (re)define world -> <vehicle>_origin, published at once."""
        lla = origin_from_message(msg)
        if lla is None:
            return
        for ts in self.origins.on_origin(v.name, lla):
            try:
                ts = self.tree.add_static(ts, ORIGIN)
            except (TransformException, ValueError) as exc:
                self.warn_once(f"origin-{ts.child_frame_id}", f"{ts.child_frame_id}: refused: {exc}")
                continue
            t = ts.transform.translation
            o = self.origins.origins[ts.child_frame_id[:-len("_origin")]]
            self.log(f"{ts.frame_id} -> {ts.child_frame_id}: {t[0]:.2f} {t[1]:.2f} {t[2]:.2f} m NED "
                     f"(GPS_GLOBAL_ORIGIN {o[0]:.7f},{o[1]:.7f},{o[2]:.2f})")
            self.send_own_to_gcs(transform_message(ts, static=True))

    def ask_origins(self, now: float) -> None:
        """REQUEST_MESSAGE(GPS_GLOBAL_ORIGIN) to every vehicle that is up and has not said."""
        for v in self.vehicles.values():
            up = v.last_heartbeat_wall is not None or v.last_pos_wall > -1e9
            if up and self.origins.wanted(v.name, now):
                self.command(v, tl.MAV_CMD_REQUEST_MESSAGE, MSG_GPS_GLOBAL_ORIGIN)

    def world_position(self, v: VehicleRecord, local) -> tuple | None:
        """A vehicle's local NED (m, from its origin) in world, None until its origin is known."""
        if not self.origins.known(v.name):
            return None
        off = self.origins.edge(v.name).transform.translation
        return (local[0] + off[0], local[1] + off[1], local[2] + off[2])

    def on_heartbeat(self, v: VehicleRecord, msg, now: float) -> None:
        first = v.last_heartbeat_wall is None
        v.custom_mode = msg.custom_mode
        v.armed = bool(msg.base_mode & tl.MAV_MODE_FLAG_SAFETY_ARMED)
        v.last_heartbeat_wall = now
        if first:
            self.log(f"{v.name} (sysid {v.sysid}) is up: mode {msg.custom_mode}, "
                     f"{'armed' if v.armed else 'disarmed'}")
            self.request_streams(v, force=True)
            self.clocks.request_system_time(v, force=True)

    def request_streams(self, v: VehicleRecord, force: bool = False) -> None:
        if self.cfg.telemetry_rate <= 0:
            return
        now = self.clock()
        if not force and now - v.last_stream_req < STREAM_REQUEST_PERIOD:
            return
        v.last_stream_req = now
        interval = 1e6 / self.cfg.telemetry_rate
        for mid in (MSG_LOCAL_POSITION_NED, MSG_ATTITUDE_QUATERNION):
            self.command(v, tl.MAV_CMD_SET_MESSAGE_INTERVAL, mid, interval)

    # ------------------------------------------------------------------ frames
    def on_frame_sample(self, v: VehicleRecord, s) -> None:
        """A paired sample on the vehicle's own clock: onto the one timeline, or held back."""
        shift = self.clocks.place(v, ("frame", s))
        if shift is not None:
            self.frame_on_timeline(v, s, shift)

    def release_held(self) -> None:
        for v, s, shift in self.clocks.release(self.vehicles):
            self.frame_on_timeline(v, s, shift)

    def frame_on_timeline(self, v: VehicleRecord, s, shift: float) -> None:
        if self.cfg.route_only:
            return          # --route-only: the vehicles' frames are the nodes' to publish
        if shift:
            t = s.stamp + shift
            s = replace(s, stamp=t, full=replace(s.full, stamp=t), yaw=replace(s.yaw, stamp=t))
        reset = self.timeline.frame_stamp(v.name, s.stamp)
        if reset:
            self.log(f"{v.name}: clock went back to {s.stamp:.3f} s on the timeline (reboot): "
                     f"its frames are reset")
        try:
            publish = self.tree.add_sample(v.name, s, reset)
        except TransformException as exc:
            self.warn_once(f"set-{v.name}", f"{v.name}: transform rejected: {exc}")
            return
        if publish:
            self.send_own_to_gcs(transform_message(s.full))
            self.send_own_to_gcs(transform_message(s.yaw))
        pair = self.followers.get(v.sysid)
        rover = self.vehicles.get(pair[1]) if pair else None
        if self.cfg.follow and rover is not None:
            self.send_out(pair[0].on_drone_sample(s.stamp, s.velocity, reset, rover), rover)
