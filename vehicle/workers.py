"""One world over several processes (`towerlink sitl --workers K`): Python runs one core per
process, so a world that needs more than a core is split.

The network plan is the whole world's (vehicle/network_plan.py: sysids, ports, --out per
network); worker w runs the contiguous share of vehicles [w*n/K, (w+1)*n/K), each with
its own endpoints, exactly as in one process (vehicle j's noise is seeded [seed, j]
wherever it runs). Vehicles do not interact, so the only thing the processes share is time:
the parent waits until every worker has built its share, then hands out one unix instant
as sim t = 0, and each worker paces itself to the wall clock from it (at --speedup 1 all
run at real time; a worker that cannot keep up falls behind alone, and says so in its
behind count). Workers are forked (they start with the parent's imports); they stop on
SIGTERM/SIGINT, when the parent goes away, or when told to; the parent stops when a worker
dies. Each prints its own stats line at exit.

With --lockstep N each worker runs its own gate (vehicle/lockstep.py) for its own
vehicles and waits at t = 0 for the same N participants, which join every vehicle link. Then
the wall instant does not matter: a participant ACKs TICK(t) only when TICK(t) came on all its
links (bridge.lockstep_desk's barrier), so no worker passes t before every worker reached it
and the processes step as one world, at --speedup N or max.

Not shared: world-wide state changed at run time (a PARAM_SET of SIM_WIND_* moves the air
of the worker that received it only; --wind at start is every worker's). Refused by the CLI:
--workers with --speedup max without --lockstep (each worker would run at its own CPU's pace).
"""
from __future__ import annotations

import asyncio
import multiprocessing as mp
import signal
import sys
import threading
import time
from dataclasses import replace

from common.collector import tune_for_long_run
from vehicle.world import World, WorldConfig

READY_TIMEOUT = 300.0     # wall s for a worker to build its share
START_DELAY = 0.3         # wall s between handing out t = 0 and reaching it


def shares(n: int, k: int) -> list[tuple[int, int]]:
    """Contiguous vehicle index ranges [lo, hi) of k workers over n vehicles (none empty)."""
    k = max(1, min(k, n))
    return [(w * n // k, (w + 1) * n // k) for w in range(k)]


def _child(cfg: WorldConfig, conn) -> None:
    try:
        world = World(cfg)
    except Exception as e:               # noqa: BLE001 - reported to the parent, which prints it
        conn.send(("error", f"{type(e).__name__}: {e}"))
        sys.exit(1)
    try:
        conn.send(("ready", None))
        msg = conn.recv() if conn.poll(READY_TIMEOUT) else ("stop", None)
    except (EOFError, OSError):          # the parent went away before the start
        return
    if msg[0] != "start":
        return
    world.set_start(msg[1])

    def watch_parent() -> None:          # EOF or "stop": the parent is done
        try:
            conn.recv()
        except (EOFError, OSError):
            pass
        world.request_stop()

    async def main() -> None:
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, world.request_stop)
        threading.Thread(target=watch_parent, daemon=True).start()
        await world.run()
    tune_for_long_run()                  # this share's vehicles are built (common/collector.py)
    try:
        asyncio.run(main())
    except OSError as e:                 # a port taken after the plan was made
        print(f"towerlink sitl: worker {cfg.share}: {e}", file=sys.stderr, flush=True)
        sys.exit(1)
    sys.stdout.write(world.stats_line() + "\n")    # one write: workers share the terminal
    sys.stdout.flush()


def run(cfg: WorldConfig, k: int, out=print, on_world=None) -> int:
    """Run the world of `cfg` over k processes (this one runs the first share). Returns the
    exit status: 0, or 1 when a worker failed."""
    n = cfg.drones + cfg.rovers
    parts = shares(n, k)
    ctx = mp.get_context("fork")
    kids = []
    for share in parts[1:]:
        parent_end, child_end = ctx.Pipe()
        p = ctx.Process(target=_child, args=(replace(cfg, share=share), child_end), daemon=False)
        p.start()
        child_end.close()
        kids.append((p, parent_end))
    try:
        world = World(replace(cfg, share=parts[0]))
        if on_world is not None:
            on_world(world)
        for p, conn in kids:
            if not conn.poll(READY_TIMEOUT):
                raise RuntimeError("a worker did not start")
            kind, detail = conn.recv()
            if kind != "ready":
                raise RuntimeError(detail)
        start_at = time.time() + START_DELAY
        for _, conn in kids:
            conn.send(("start", start_at))
        world.set_start(start_at)
        failed = []

        async def main() -> None:
            loop = asyncio.get_running_loop()
            for sig in (signal.SIGTERM, signal.SIGINT):
                loop.add_signal_handler(sig, world.request_stop)

            async def watchdog() -> None:
                while True:
                    await asyncio.sleep(0.5)
                    dead = [p for p, _ in kids if not p.is_alive()]
                    if dead:             # a share of the world is gone: stop the rest
                        failed.extend(p for p in dead if p.exitcode != 0)
                        world.request_stop()
                        return
            task = asyncio.ensure_future(watchdog())
            try:
                await world.run(started=lambda: out(world.banner(len(parts))))
            finally:
                task.cancel()
        tune_for_long_run()
        asyncio.run(main())
        out(world.stats_line())
        return 1 if failed else 0
    finally:
        for p, conn in kids:
            try:
                conn.send(("stop", None))
            except (OSError, ValueError):
                pass
            conn.close()
        for p, _ in kids:
            p.join(10)
            if p.is_alive():
                p.terminate()
                p.join(5)
