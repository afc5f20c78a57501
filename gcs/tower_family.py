"""The tower's family of drones and its moving frame (issue 12).

* :class:`TowerFrames`: the bridge's transform stream on the tower link in a Buffer, and
  the time-travel questions a tower on a van asks (where a stamped goal lies in world,
  where a world point lies in the tower frame now).
* :class:`SeparationWatch`: the closest 3-D approach of two airborne drones, logged when
  below the scenario's min_separation.
* :func:`run_family`: `towerlink tower` for a scenario with several drones (or a van):
  one connection, thread and gcs.tower.Mission per drone, take-offs from the highest
  altitude layer down, one result file for all. With --lockstep each connection is a
  participant of its own (compid 190 + k: the world tells participants apart by sysid
  and compid) that keeps polling, so ACKing, while it waits for the layer above, and
  leaves (closes) as soon as its drone is done, so the world never waits for it idle.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from collections.abc import Callable, Sequence

from gcs.tower import Mission, MissionResult


class TowerFrames:
    """The bridge's transform stream on the tower link, kept in a Buffer (tf2's TransformListener).

    Fed with every received message (Client.add_listener); answers, for a frame hanging
    on a moving vehicle, where a goal stamped t lies in world and where a world point
    lies in that frame now. Frames: world is the fixed frame; positions are m, NED.
    """

    def __init__(self, fixed: str = "world", cache_time: float = 30.0) -> None:
        from gcs.frames import Buffer
        from gcs.tf2_ros.stream import TransformStream
        self.fixed = fixed
        self.buffer = Buffer(cache_time=cache_time)
        self.stream = TransformStream(self.buffer)     # tf2_ros's listener core: stream -> buffer
        self.lock = threading.Lock()

    def on_message(self, msg) -> None:
        """Client listener: every received message (only TOWERLINK_TRANSFORM is kept)."""
        if msg.get_type() == "TOWERLINK_TRANSFORM":
            with self.lock:             # several connections feed one buffer
                self.stream.feed(msg)

    def moving(self, frame: str) -> bool:
        """Does `frame` hang on a dynamic edge below the fixed frame?"""
        from gcs.frames import TransformException
        with self.lock:
            try:
                stats = self.buffer.edge_stats()
                return any(f in stats and not stats[f].is_static for f in self.buffer.chain(self.fixed, frame))
            except TransformException:
                return False

    def world_point(self, frame: str, p: Sequence[float], stamp: float | None):
        """`p` in `frame` at `stamp`, in the fixed frame (tf2 time travel); None until known."""
        from gcs.frames import TransformException
        if stamp is None:
            return None
        with self.lock:
            try:
                T = self.buffer.lookup_transform_full(self.fixed, stamp, frame, stamp, self.fixed)
            except TransformException:
                return None
        return tuple(float(v) for v in T.transform.apply_point(p))

    def seen_from(self, frame: str, world: Sequence[float]):
        """A fixed-frame point in `frame` with the latest transform; None if unknown."""
        from gcs.frames import LATEST, TransformException
        with self.lock:
            try:
                T = self.buffer.lookup_transform(frame, self.fixed, LATEST)
            except TransformException:
                return None
        return tuple(float(v) for v in T.transform.apply_point(world))

    def latest_offset(self, frame: str, p: Sequence[float], world: Sequence[float]) -> float | None:
        """How far `p` in `frame` resolved with the latest transform lands from `world`, m."""
        from gcs.frames import LATEST, TransformException
        with self.lock:
            try:
                T = self.buffer.lookup_transform(self.fixed, frame, LATEST)
            except TransformException:
                return None
        return float(math.dist(T.transform.apply_point(p), world))


class SeparationWatch:
    """The smallest 3-D distance between two airborne drones (tower frame, m), logged when low.

    Fed LOCAL_POSITION_NED from any client (all drones' telemetry reaches every tower
    connection). Airborne: more than 1 m above where the drone was first seen.
    """

    AIRBORNE = 1.0

    def __init__(self, names: dict[int, str], minimum: float, log: Callable[[str], None]) -> None:
        self.names = names
        self.minimum = minimum
        self.log = log
        self.pos: dict[int, tuple[float, float, float]] = {}
        self.ground: dict[int, float] = {}
        self.closest: float | None = None
        self.closest_pair: tuple[str, str] | None = None
        self.breaches = 0
        self._last_log = -1e9
        self.lock = threading.Lock()

    def on_message(self, msg) -> None:
        if msg.get_type() != "LOCAL_POSITION_NED":
            return
        s = msg.get_srcSystem()
        if s not in self.names:
            return
        with self.lock:
            p = (float(msg.x), float(msg.y), float(msg.z))
            self.ground.setdefault(s, p[2])
            self.pos[s] = p
            if self.ground[s] - p[2] < self.AIRBORNE:
                return
            for o, q in self.pos.items():
                if o == s or self.ground[o] - q[2] < self.AIRBORNE:
                    continue
                d = math.dist(p, q)
                if self.closest is None or d < self.closest:
                    self.closest, self.closest_pair = d, (self.names[s], self.names[o])
                if d < self.minimum:
                    self.breaches += 1
                    now = time.monotonic()
                    if now - self._last_log > 1.0:
                        self._last_log = now
                        self.log(f"separation: {self.names[s]} and {self.names[o]} {d:.2f} m apart "
                                 f"(minimum {self.minimum:g} m)")


def run_family(args: argparse.Namespace, sc, *, radius: float, finish: str, frame: str) -> int:
    """Every drone of the scenario at once: one connection, thread and Mission per drone."""
    from gcs.client import Client, ClientError

    out_lock = threading.Lock()

    def logger(name: str) -> Callable[[str], None]:
        def log(msg: str) -> None:
            with out_lock:
                print(f"tower: {name}: {msg}" if name else f"tower: {msg}", flush=True)
        return log

    log = logger("")
    drones = [d for d in sc.drones if d.goals]
    if not drones:
        print("tower: the scenario has no goals", file=sys.stderr)
        return 2
    log(f"scenario {sc.name}: {len(drones)} drone(s) "
        + ", ".join(f"{d.name} (sysid {d.sysid}, {d.altitude:g} m, {len(d.goals)} goals)" for d in drones)
        + f" in frame {frame!r}; radius {radius:g} m, finish {finish}; link {args.connect}")
    frames = TowerFrames()
    watch = SeparationWatch({d.sysid: d.name for d in sc.drones}, sc.min_separation, log)
    # take off from the highest layer down: each waits for the layer above to be held
    order = sorted(drones, key=lambda d: -d.altitude)
    gates = {d.sysid: threading.Event() for d in order}
    clients, missions = [], []
    lockstep = bool(getattr(args, "lockstep", False))

    def hold(c, e: threading.Event, name: str) -> None:
        """Wait for the layer above: with lockstep keep polling (each poll ACKs a TICK, and
        the deadline counts sim seconds), else block on the event."""
        logger(name)("waiting for the layer above to be held")
        if not lockstep:
            e.wait(args.goal_timeout)
            return
        end = c.clock() + args.goal_timeout
        while not e.is_set() and c.clock() < end:
            c.poll(0.05)
    try:
        for k, d in enumerate(drones):
            tlog = args.tlog if k == 0 else None     # one recording of the link is enough
            c = Client.connect(args.connect, log=logger(d.name), tlog=tlog, lockstep=lockstep,
                               source_component=190 + k if lockstep else 190)
            clients.append(c)
            # every connection gets the whole stream; each feeds the shared frames and watch
            # (both locked), so they stay current while any drone is still flying
            c.add_listener(frames.on_message)
            c.add_listener(watch.on_message)
            i = order.index(d)
            above = gates[order[i - 1].sysid] if i > 0 else None
            goals = [(x, y, z) for x, y, z in d.goals]
            missions.append(Mission(
                c, goals, altitude=d.altitude, radius=radius, finish=finish, frame=frame,
                goal_timeout=args.goal_timeout, resend=args.resend, sysid=d.sysid,
                connect_timeout=args.connect_timeout, arm_timeout=args.connect_timeout,
                log=logger(d.name), frames=frames,
                before_takeoff=(lambda e=above, n=d.name, c=c: hold(c, e, n)) if above is not None else None,
                after_takeoff=gates[d.sysid].set))
    except ClientError as exc:
        log(str(exc))
        for c in clients:
            c.close()
        return 2
    results: dict[int, MissionResult] = {}

    def fly(m: Mission) -> None:
        try:
            results[m.sysid] = m.run()
        except KeyboardInterrupt:
            m.result.error = "interrupted"
            results[m.sysid] = m.result
        finally:
            gates[m.sysid].set()           # never leave a lower layer waiting for a failed drone
            if lockstep:
                m.c.close()                # LEAVE now: the world must not wait for an idle link

    threads = [threading.Thread(target=fly, args=(m,), name=f"tower-{d.name}", daemon=True)
               for m, d in zip(missions, drones)]
    for t in threads:
        t.start()
    try:
        for t in threads:
            while t.is_alive():
                t.join(0.2)
    except KeyboardInterrupt:
        log("interrupted")
    finally:
        for c in clients:
            c.close()
    out = {"ok": all(results.get(d.sysid) is not None and results[d.sysid].ok for d in drones),
           "scenario": sc.name, "frame": frame, "radius": radius, "finish": finish,
           "min_separation": sc.min_separation,
           "separation": {"closest_m": watch.closest, "pair": watch.closest_pair,
                          "samples_below_minimum": watch.breaches},
           "drones": []}
    for d in drones:
        r = results.get(d.sysid) or MissionResult(error="did not run")
        out["drones"].append({"name": d.name, "sysid": d.sysid, "altitude": d.altitude,
                              "rover": d.rover, "rover_sysid": d.rover_sysid, **r.to_json()})
    if args.result:
        with open(args.result, "w") as f:
            json.dump(out, f, indent=2)
    total = sum(len(d.goals) for d in drones)
    reached = sum(g["reached"] for dd in out["drones"] for g in dd["goals"])
    sep = "-" if watch.closest is None else f"{watch.closest:.2f} m ({' and '.join(watch.closest_pair)})"
    log(f"closest approach of two airborne drones: {sep}; minimum {sc.min_separation:g} m")
    log(f"{'MISSION OK' if out['ok'] else 'MISSION FAILED'}: {reached}/{total} goals reached "
        f"by {len(drones)} drone(s)")
    return 0 if out["ok"] else 1
