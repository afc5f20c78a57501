"""What the bridge does on a clock rather than on a packet.

* :class:`SimChecks`: goal retries and the followers' checks. They decide behaviour, so they
  run on the behaviour clock: every wall tick, or with --lockstep at every barrier of the
  world's TICKs (sim time), so they happen at the same sim time every run.
* :class:`Upkeep`: the wall-clock pass every loop TICK: the links' own upkeep (tcp
  reconnects, silent UDP peers), held samples released, origins asked for (with --lockstep
  at the barriers instead), the lockstep desk's resends, and at their periods the heartbeat to the vehicles (with stream requests
  for one whose telemetry stopped), TIMESYNC probes, the static frames republished and
  TOWERLINK_BRIDGE_STATUS; then what is queued for the GCS links is written.
"""
from __future__ import annotations

from collections.abc import Callable

from common.mavlink.dialect import towerlink as tl
from common.tf2_ros.wire import transform_message
from bridge.clock_desk import ClockDesk
from bridge.codec import Codec, bridge_status_message
from bridge.config import VehicleRecord
from bridge.frame_tree import FrameTree
from bridge.goals import GoalDesk
from bridge.lockstep_desk import LockstepDesk
from bridge.router import Router
from bridge.telemetry import TelemetryDesk
from bridge.timeline import Timeline

HEARTBEAT_PERIOD = 1.0          # wall s between the bridge's HEARTBEATs to the vehicles
STATIC_PERIOD = 1.0             # wall s between republishing static transforms
STATUS_PERIOD = 1.0
TIMESYNC_PERIOD = 1.0           # wall s between TIMESYNC probes of each vehicle link
TELEMETRY_STOPPED = 2.0         # behaviour-clock s without a vehicle's pose: ask for its streams again


class SimChecks:
    """Goal retries and the followers' checks, on the behaviour clock."""

    def __init__(self, goals: GoalDesk, followers: dict, vehicles: dict[int, VehicleRecord], router: Router,
                 timeline: Timeline, follow: bool) -> None:
        self.goals = goals
        self.followers = followers          # drone sysid -> (Follower, rover sysid)
        self.vehicles = vehicles
        self.router = router
        self.timeline = timeline
        self.follow = follow

    def run(self, rover_clock: Callable) -> None:
        """Goal retries and the followers' checks; rover_clock(rover) -> (its newest stamp on the
        timeline, now), s."""
        self.goals.retry()
        if self.follow:
            for follower, rsys in self.followers.values():
                rover = self.vehicles.get(rsys)
                if rover is not None:
                    self.router.send_out(follower.check(rover, *rover_clock(rover)), rover)

    def on_wall_tick(self) -> None:
        """Without --lockstep: every wall tick, the rover's staleness judged on the wall clock."""
        self.run(lambda rover: self.timeline.newest(rover.name))

    def at_barrier(self, t: float) -> None:
        """The lockstep barrier reached sim time t (s): the sim-time upkeep, before the ACK."""
        # the rover's clock is live by construction (the world ticked): stale is judged on stamps
        self.run(lambda rover: (self.timeline.newest(rover.name)[0], t))


class Upkeep:
    """The wall-clock pass of every loop TICK."""

    def __init__(self, links: list, vehicles: dict[int, VehicleRecord], router: Router, codec: Codec,
                 telemetry: TelemetryDesk, clocks: ClockDesk, tree: FrameTree, sim_checks: SimChecks,
                 lockstep: LockstepDesk | None, behaviour_clock: Callable[[], float],
                 clock: Callable[[], float], t0: float) -> None:
        self.links = links                  # every link, GCS-side first
        self.vehicles = vehicles
        self.router = router
        self.codec = codec
        self.telemetry = telemetry
        self.clocks = clocks
        self.tree = tree
        self.sim_checks = sim_checks
        self.lockstep = lockstep
        self.behaviour_clock = behaviour_clock
        self.clock = clock                  # () -> wall s
        self.t0 = t0                        # the bridge's start, wall s
        self._next = {"hb": 0.0, "timesync": 0.0, "static": 0.0, "status": 0.0}

    def _due(self, what: str, now: float, period: float) -> bool:
        if now >= self._next[what]:
            self._next[what] = now + period
            return True
        return False

    def tick(self) -> None:
        """One upkeep pass (see the module docstring), then the GCS links flushed."""
        now = self.clock()
        for link in self.links:
            link.poll()
        self.telemetry.release_held()
        if self.lockstep is None:           # with lockstep at the barriers (on sim time)
            self.telemetry.ask_origins(now)
        if self.lockstep is None:
            self.sim_checks.on_wall_tick()
        else:
            self.lockstep.upkeep(now)
        bnow = self.behaviour_clock()
        if self._due("hb", now, HEARTBEAT_PERIOD):
            data = self.codec.pack_own(tl.MAVLink_heartbeat_message(
                tl.MAV_TYPE_ONBOARD_CONTROLLER, tl.MAV_AUTOPILOT_INVALID, 0, 0, tl.MAV_STATE_ACTIVE, 3))
            for v in self.vehicles.values():
                v.link.send(data)
                if v.last_heartbeat_wall is not None and (bnow - v.last_att_wall > TELEMETRY_STOPPED or
                                                          bnow - v.last_pos_wall > TELEMETRY_STOPPED):
                    self.telemetry.request_streams(v)
        if self._due("timesync", now, TIMESYNC_PERIOD):
            self.clocks.probe(self.vehicles, now)
        if self._due("static", now, STATIC_PERIOD):
            for ts in self.tree.static_transforms():
                self.router.send_own_to_gcs(transform_message(ts, static=True))
        if self._due("status", now, STATUS_PERIOD):
            usec = int((now - self.t0) * 1e6)
            for link in self.links:         # each read after the ones before were queued
                self.router.send_own_to_gcs(bridge_status_message(usec, link.name, link.stats, link.malformed))
        self.router.flush_gcs()
