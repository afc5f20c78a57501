"""The tower's family of drones: every drone of a scenario at once, on one link.

* :class:`SeparationWatch`: the closest 3-D approach of two airborne drones, logged when
  below the scenario's min_separation.
* :class:`LayerGates`: take-offs from the highest altitude layer down.
* :func:`run_family`: `towerlink tower` for a scenario with several drones (or a van):
  one link (gcs.tower_link), a thread and gcs.tower_mission.Mission per drone, the moving
  tower's frames (gcs.tower_frames), one result file for all.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from collections.abc import Callable

from gcs.tower_frames import TowerFrames
from gcs.tower_mission import Mission, MissionResult


class SeparationWatch:
    """The smallest 3-D distance between two airborne drones (tower frame, m), logged when low.

    Fed LOCAL_POSITION_NED (every drone's telemetry reaches the tower link). Airborne: more
    than 1 m above where the drone was first seen. Each sample is compared only with the
    drones in its own and the neighbouring cells of a grid `cell` m wide (O(N) per tick for
    N drones, not O(N**2)); a closest approach wider than `cell` is not tracked (None).
    """

    AIRBORNE = 1.0

    def __init__(self, names: dict[int, str], minimum: float, log: Callable[[str], None],
                 cell: float | None = None) -> None:
        self.names = names
        self.minimum = minimum
        self.log = log
        self.cell = cell if cell is not None else max(10.0, 3.0 * minimum)
        self.pos: dict[int, tuple[float, float, float]] = {}
        self.ground: dict[int, float] = {}
        self._key: dict[int, tuple[int, int, int]] = {}
        self._grid: dict[tuple[int, int, int], set[int]] = {}
        self.closest: float | None = None
        self.closest_pair: tuple[str, str] | None = None
        self.breaches = 0
        self._last_log = -1e9
        self.lock = threading.Lock()

    def _place(self, s: int, p: tuple[float, float, float]) -> tuple[int, int, int]:
        c = self.cell
        key = (math.floor(p[0] / c), math.floor(p[1] / c), math.floor(p[2] / c))
        old = self._key.get(s)
        if old != key:
            if old is not None:
                self._grid[old].discard(s)
            self._grid.setdefault(key, set()).add(s)
            self._key[s] = key
        return key

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
            kx, ky, kz = self._place(s, p)
            if self.ground[s] - p[2] < self.AIRBORNE:
                return
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        for o in self._grid.get((kx + dx, ky + dy, kz + dz), ()):
                            q = self.pos[o]
                            if o == s or self.ground[o] - q[2] < self.AIRBORNE:
                                continue
                            self._pair(s, o, math.dist(p, q))

    def _pair(self, s: int, o: int, d: float) -> None:
        if self.closest is None or d < self.closest:
            self.closest, self.closest_pair = d, (self.names[s], self.names[o])
        if d < self.minimum:
            self.breaches += 1
            now = time.monotonic()
            if now - self._last_log > 1.0:
                self._last_log = now
                self.log(f"separation: {self.names[s]} and {self.names[o]} {d:.2f} m apart "
                         f"(minimum {self.minimum:g} m)")


class LayerGates:
    """Take-off order by altitude layer: the highest layer first, each layer once every drone
    of the layer above holds its height (or has given up), so no climb passes a drone closer
    than the layer spacing. Drones of one layer climb together."""

    def __init__(self, altitudes: dict[int, float]) -> None:
        self.layers = sorted(set(altitudes.values()), reverse=True)
        self.altitude = altitudes
        self._left = {a: sum(1 for v in altitudes.values() if v == a) for a in self.layers}
        self._done: set[int] = set()
        self._lock = threading.Lock()

    def above(self, sysid: int) -> float | None:
        """The layer this drone waits for (None: the highest, it goes first)."""
        k = self.layers.index(self.altitude[sysid])
        return self.layers[k - 1] if k > 0 else None

    def done(self, sysid: int) -> None:
        """This drone holds its layer (or failed); a second call for it changes nothing."""
        with self._lock:
            if sysid not in self._done:
                self._done.add(sysid)
                self._left[self.altitude[sysid]] -= 1

    def held(self, layer: float) -> bool:
        with self._lock:
            return self._left[layer] <= 0


def run_family(args: argparse.Namespace, sc, *, radius: float, finish: str, frame: str) -> int:
    """Every drone of the scenario at once: one link (gcs.tower_link), a thread and Mission per drone."""
    from gcs.client import ClientError
    from gcs.tower_link import SharedClient

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
    lockstep = bool(getattr(args, "lockstep", False))
    if len(drones) <= 10:
        log(f"scenario {sc.name}: {len(drones)} drone(s) "
            + ", ".join(f"{d.name} (sysid {d.sysid}, {d.altitude:g} m, {len(d.goals)} goals)" for d in drones)
            + f" in frame {frame!r}; radius {radius:g} m, finish {finish}; link {args.connect}")
    else:
        layers = sorted({d.altitude for d in drones})
        log(f"scenario {sc.name}: {len(drones)} drones (sysids {drones[0].sysid}..{drones[-1].sysid}) on "
            f"{len(layers)} layer(s) {', '.join(f'{a:g}' for a in layers)} m, "
            f"{sum(len(d.goals) for d in drones)} goals in frame {frame!r}; radius {radius:g} m, "
            f"finish {finish}; link {args.connect}")
    if getattr(args, "signing_key", None):
        log("MAVLink 2 signing on: the link sends and accepts only packets signed with the key")
    frames = TowerFrames()
    watch = SeparationWatch({d.sysid: d.name for d in sc.drones}, sc.min_separation, log)
    gates = LayerGates({d.sysid: d.altitude for d in drones})
    try:
        # one link for the whole family: the bridge sends every drone's telemetry to each peer
        from common.mavlink.signing import key_from_text
        c = SharedClient.connect(args.connect, log=log, tlog=args.tlog, lockstep=lockstep,
                                 signing_key=key_from_text(getattr(args, "signing_key", None)))
    except ClientError as exc:
        log(str(exc))
        return 2
    # subscribed to the two messages they read: the link leaves the rest undecoded (gcs.client.lazy_rx)
    c.subscribe("TOWERLINK_TRANSFORM", frames.on_message)
    c.subscribe("LOCAL_POSITION_NED", watch.on_message)

    def before_takeoff(d) -> Callable[[], None] | None:
        layer = gates.above(d.sysid)
        if layer is None:
            return None

        def wait() -> None:
            # wait disarmed (an armed copter left on the ground disarms itself: DISARM_DELAY),
            # parked on the link so the lockstep barrier counts this thread as done
            if not gates.held(layer):
                logger(d.name)(f"waiting for the layer above ({layer:g} m) to be held")
                c.wait_until(lambda: gates.held(layer), args.goal_timeout)
        return wait

    missions = [Mission(
        c, [(x, y, z) for x, y, z in d.goals], altitude=d.altitude, radius=radius, finish=finish,
        frame=frame, goal_timeout=args.goal_timeout, resend=args.resend, sysid=d.sysid,
        connect_timeout=args.connect_timeout, arm_timeout=args.connect_timeout,
        log=logger(d.name), frames=frames, before_takeoff=before_takeoff(d),
        after_takeoff=(lambda s=d.sysid: gates.done(s))) for d in drones]
    results: dict[int, MissionResult] = {}

    def fly(m: Mission) -> None:
        c.member()
        try:
            results[m.sysid] = m.run()
        except KeyboardInterrupt:
            m.result.error = "interrupted"
            results[m.sysid] = m.result
        finally:
            gates.done(m.sysid)            # never leave a lower layer waiting for a failed drone
            c.leave()

    threads = [threading.Thread(target=fly, args=(m,), name=f"tower-{d.name}", daemon=True)
               for m, d in zip(missions, drones)]
    c.start()
    for t in threads:
        t.start()
    try:
        for t in threads:
            while t.is_alive():
                t.join(0.2)
    except KeyboardInterrupt:
        log("interrupted")
    finally:
        c.close()
    if c.signing_report():
        log(c.signing_report())
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
