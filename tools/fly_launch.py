"""A `towerlink fly` run: the world, the bridge, the tower (and nodes, the tower link's proxy, a van's
driver, ArduPilot's follow driver, the live view) started in order, watched, stopped.

Used by `towerlink fly` (tools.fly) and by the full-system tests, which also kill and restart
the bridge. When the tower link has faults, or the scenario a fault timeline, the tower talks
through tools.link_proxy, which also applies the vehicles' faults. `stop()` always leaves
nothing behind.
"""
from __future__ import annotations

import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable

from common.mavlink.signing import SIGNING_FLAG, masked_argv
from tools.fly_drawings import Drawings
from tools.fly_monitor import Monitor
from tools.fly_plan import FlyPlan
from tools.fly_processes import ProcessGroup
from tools.fly_progress import WAITING, GoalState, ProgressReporter, SpeedupMeter, TowerOutput, goal_text
from tools.fly_recorder import Recorder
from tools.fly_run_folder import tower_end_sim, write_meta, write_summary
from tools.fly_van import VanDriver
from tools.run_ids import DRONE, SCORING_PARAMS

os.environ.setdefault("MAVLINK20", "1")     # the children inherit it

# After the tower's end the world runs on until the monitor has recorded this much sim time
# past it (the truth just after the last goal is read by the summary), for at most TAIL_WALL_S.
TAIL_SIM_S = 0.2
TAIL_WALL_S = 2.0


class Launch:
    """The processes of one run and the monitor.

    `Launch(run_dir, **options)`: the options are FlyPlan's (scenario, speedup, seed, lockstep,
    world, signing_key, ...); `echo` prints the tower's lines, `view_port` serves the run live
    to Foxglove (None: no live view; 0: any free port).
    """

    def __init__(self, run_dir: str | os.PathLike, *, echo: bool = False, view_port: int | None = None,
                 **options) -> None:
        self.plan = FlyPlan(run_dir, **options)
        self.dir = self.plan.dir
        self.echo = echo
        self.view_port = view_port
        self.processes = ProcessGroup(self.dir)
        self.tower = TowerOutput()
        self.speedup = SpeedupMeter()
        self.monitor: Monitor | None = None
        self.proxy = None
        self.view = None
        self.ap_driver = None
        self.van_driver: VanDriver | None = None
        self.bridge_restarts = 0
        self._world_asked = False

    # -- what the tests and the CLI look at

    @property
    def ports(self) -> dict[str, int]:
        return self.plan.ports

    @property
    def procs(self) -> dict[str, subprocess.Popen]:
        return self.processes.procs

    @property
    def goal_state(self) -> GoalState:
        return self.tower.goals

    @property
    def tower_lines(self) -> list[str]:
        return self.tower.lines

    def alive(self) -> dict[str, bool]:
        return self.processes.alive()

    # -- starting

    def start(self) -> None:
        """Monitor, world, (van driver), bridge, (nodes), (link proxy), tower: in that order."""
        plan = self.plan
        self.monitor = Monitor(self.dir, {"vehicles": plan.ports["vehicles"], "bridge": plan.ports["bridge"]},
                               plan.host, {"vehicles": plan.world_binds()[1]}, signing_key=plan.key(),
                               lockstep=plan.lockstep)
        if self.view_port is not None:
            from tools.live_view import LiveView
            self.view = LiveView(plan.host, self.view_port)
            self.monitor.listeners["bridge"] = self.view.on_message
        if plan.ap_follower is not None:
            from tools.follow_ap import ApFollowDriver
            self.ap_driver = ApFollowDriver(self.monitor.send_to_vehicle, plan.ap_follower, DRONE,
                                            plan.sc.follow_offset, plan.foll_pos_p)
            self.monitor.listeners["vehicles"] = self.ap_driver.on_message
        self.monitor.start()
        self.start_world()
        if plan.family and plan.sc.van is not None:
            self.van_driver = VanDriver(plan.sc.van, f"udpout:{plan.world_addr}:{plan.ports['van_driver']}",
                                        self.dir / "van.log", lockstep=plan.lockstep, signing_key=plan.key())
            self.van_driver.start()
        self.start_bridge()
        for path in plan.nodes:
            self.processes.start(f"node-{path.stem}", plan.node_cmd(path), env=plan.node_env())
        if plan.uses_proxy:
            self.proxy = self._link_proxy()
            self.proxy.start()
        self.processes.start("tower", plan.tower_cmd(), on_line=self._tower_line)
        write_meta(plan)

    def _link_proxy(self):
        """The tower link's proxy: its faults, and the hand that applies the vehicles' faults."""
        from tools.fault_params import ParamSetEncoder
        from tools.link_proxy import LinkProxy, bridge_wall_paced
        plan = self.plan
        return LinkProxy(plan.ports["proxy"], (plan.host, plan.ports["tower"]), seed=plan.loss_seed, host=plan.host,
                         lockstep=plan.lockstep, exempt=bridge_wall_paced if plan.lockstep else None,
                         timeline=plan.timeline, encode=ParamSetEncoder(plan.key()), sim_time=self.monitor.sim_time)

    def start_world(self) -> None:
        """Start the world, or (attach) print the command that starts it on its host; once (its
        start-up is the run's longest: `towerlink fly` starts it before anything else)."""
        if self._world_asked:
            return
        self._world_asked = True
        plan = self.plan
        if plan.world is not None and plan.world.attach:      # the user starts it there
            hint = f"\n  (put your {SIGNING_FLAG} where *** stands)" if plan.signing_key else ""
            print(f"towerlink fly: start the world on {plan.world.addr}:\n  "
                  f"{shlex.join(masked_argv(plan.world_cmd()))}{hint}", flush=True)
            return
        self.processes.start("sitl", plan.world_cmd())

    def start_bridge(self) -> subprocess.Popen:
        return self.processes.start("bridge", self.plan.bridge_cmd())

    def kill_bridge(self, sig: int = signal.SIGKILL) -> None:
        """Kill the bridge (SIGKILL by default: no goodbye), e.g. to prove the drone holds."""
        self.processes.kill("bridge", sig)

    def restart_bridge(self) -> subprocess.Popen:
        self.bridge_restarts += 1
        return self.start_bridge()

    def _tower_line(self, line: str) -> None:
        sent = self.tower.feed(line)
        if sent is not None and self.view is not None:
            self.view.goal(*sent)
        if self.echo:
            print(f"  {line}", flush=True)

    # -- running

    def wait(self, timeout: float, progress: float | None = 1.0, out=sys.stdout,
             on_flying: Callable[[], object] | None = None) -> int | None:
        """Wait for the tower to finish (its exit status), printing progress lines at most every
        `progress` wall s (None: none); None on timeout. RuntimeError when the world or a node exits.
        `on_flying`: called once, when the sim clock first moves (the start-up is over)."""
        end = time.monotonic() + timeout
        last_params = 0.0
        reporter = ProgressReporter(self.plan.speedup, self.plan.lockstep, progress)
        family_goals = sum(len(d.goals) for d in self.plan.sc.drones) if self.plan.family else None
        while True:
            rc = self.processes.exited("tower")
            if rc is not None:
                self._record_past_the_end()
                return rc
            now = time.monotonic()
            if self.tower.over.is_set():     # its last line: the result is written, only its exit is left
                rc = self.processes.wait("tower", end - now)
                if rc is not None:
                    self._record_past_the_end()
                return rc
            for name in ("sitl", *(f"node-{p.stem}" for p in self.plan.nodes)):
                status = self.processes.exited(name)
                if status is not None:
                    raise RuntimeError(f"{name} exited with status {status}; see {self.dir / (name + '.log')}")
            # every 0.5 s until the scoring parameters have come (a short lockstep run at max
            # speed is over in a few wall seconds), then every 2 s
            missing = self.monitor is not None and any(n not in self.monitor.params for n in SCORING_PARAMS)
            if now - last_params > (0.5 if missing else 2.0) and self.monitor is not None:
                last_params = now
                self.monitor.request_params()
            if self.ap_driver is not None:
                self.ap_driver.tick()
            # the sim time on every turn (it anchors the summary's speedup figure); the poses,
            # which cost the monitor's lock and decoding, only when a line may be printed
            achieved = self.speedup.update(self.monitor.sim_time() if self.monitor else WAITING["sim"])
            if on_flying is not None and self.speedup.anchor is not None:
                on_flying()
                on_flying = None
            if reporter.due():
                snap = self.monitor.snapshot() if self.monitor else WAITING
                line = reporter.line(snap, goal_text(self.tower.goals, family_goals), achieved)
                if line is not None:
                    print(line, file=out, flush=True)
            if now > end:
                return None
            self.tower.over.wait(0.05)

    def _record_past_the_end(self, limit: float = TAIL_WALL_S) -> None:
        """Hold the stop until the monitor has heard TAIL_SIM_S of sim time past the tower's end
        (at most `limit` wall s, and not once the world has gone): a summary figure at the last
        goal reads the first truth sample after it, which must be recorded however quickly the
        processes are stopped."""
        end_sim = tower_end_sim(self.dir)
        if self.monitor is None or end_sim is None:
            return
        deadline = time.monotonic() + limit
        while self.monitor.sim_time() < end_sim + TAIL_SIM_S and time.monotonic() < deadline \
                and self.processes.exited("sitl") is None:
            time.sleep(0.002)       # poll: at --speedup max the world is there in a few ms

    # -- stopping

    def _order(self) -> list[tuple[str, int]]:
        """Who is stopped with which signal, tower first, world last."""
        return [("tower", signal.SIGINT), *((f"node-{p.stem}", signal.SIGTERM) for p in self.plan.nodes),
                ("bridge", signal.SIGTERM), ("sitl", signal.SIGTERM)]

    def _tell_to_stop(self) -> None:
        """Signal the nodes, the bridge and the world at once, so they stop side by side; not with a
        van's driver, which must leave the lockstep while the world still runs (see stop())."""
        if self.van_driver is None:
            for name, sig in self._order()[1:]:
                self.processes.tell_to_stop(name, sig)

    def stop(self) -> None:
        """Stop everything this launch started (tower first, world last); idempotent."""
        order = self._order()
        if self.van_driver is not None:
            self.van_driver.stop()
        self.processes.stop(*order[0])      # the tower: its result written, whatever stopped it
        self._tell_to_stop()
        for name, sig in order[1:]:
            if name == "bridge" and self.van_driver is not None:
                self.van_driver.join(3.0)   # it leaves the lockstep at its next TICK: the world still runs
            self.processes.stop(name, sig)
        if self.van_driver is not None:
            self.van_driver.join(3.0)
        if self.proxy is not None:
            self.proxy.stop()
        if self.monitor is not None:
            self.monitor.stop()
        if self.view is not None:
            self.view.stop()
            self.view = None
        self.processes.close_logs()

    # -- results

    def write_meta(self) -> None:
        write_meta(self.plan)

    def finish_run(self, tower_rc: int | None, drawings: Drawings | None = None,
                   recorder: Recorder | None = None, fork: bool | None = None) -> dict:
        """After stop(): score, plot, draw the frames, record run.mcap; returns the summary dict.
        `drawings`, `recorder`: children started before the run (tools.fly_drawings.DrawingWorker,
        tools.fly_recorder.Recorder); default: drawn here after the scoring, recorded in a child
        forked now (`fork` False, or None with one CPU: here too)."""
        achieved = None
        if self.monitor is not None:
            achieved = self.speedup.overall(self.monitor.snapshot()["sim"])
        proxy = self.proxy.counts() if self.proxy is not None else None
        applied = self.proxy.applied if self.proxy is not None else []
        return write_summary(self.plan, tower_rc, bridge_restarts=self.bridge_restarts, proxy=proxy,
                             achieved_speedup=achieved, applied=applied, drawings=drawings,
                             recorder=recorder, fork=fork)
