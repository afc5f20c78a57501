"""The vehicles' clocks on the wire: SYSTEM_TIME and TIMESYNC, feeding the timeline.

The timeline (bridge.timeline) is pure; this desk does its I/O and its log lines:

* every raw boot-clock reading of a vehicle goes to :meth:`ClockDesk.reading`; a restart
  the timeline notices resets the vehicle's pairing and asks for SYSTEM_TIME again;
* a paired frame sample asks :meth:`ClockDesk.place` for its shift onto the one timeline;
  while that is unknown the sample is held back (the timeline queues it), the bridge asks
  for SYSTEM_TIME, and :meth:`ClockDesk.release` gives the held samples back once it is
  known (or after --time-grace wall seconds without it, presumed to share one world);
* SYSTEM_TIME (compid 1) sets the vehicle's offset; TIMESYNC probes (1 Hz wall, ts1 = our
  wall clock in ns) measure each vehicle link's round trip, logged, never moving stamps.
"""
from __future__ import annotations

from common.mavlink.dialect import towerlink as tl
from bridge.config import VehicleRecord
from bridge.timeline import Timeline

MSG_SYSTEM_TIME = 2
RTT_LOG_PERIOD = 30.0           # wall s between round-trip log lines of a link


class ClockDesk:
    def __init__(self, timeline: Timeline, command, send, log, warn_once, clock) -> None:
        self.timeline = timeline
        self._command = command         # (vehicle, MAV_CMD, *params) -> None
        self._send = send               # (vehicle, message) -> None, packed as the bridge
        self.log = log
        self.warn_once = warn_once
        self.clock = clock

    # ------------------------------------------------------------------ readings
    def reading(self, v: VehicleRecord, boot_s: float, now: float) -> None:
        """A raw boot-clock reading (s) of `v` at bridge wall time `now`."""
        line = self.timeline
        if line.clock(v.name, boot_s, now):
            v.frames.reset()
            self.log(f"{v.name}: clock went back to {boot_s:.3f} s (reboot): its frames are reset and "
                     f"its clock offset is re-learned from SYSTEM_TIME")
            self.request_system_time(v, force=True)
        shift = self.place(v, ("clock", boot_s, now))
        if shift is not None:
            line.seen(v.name, boot_s + shift, now)

    def place(self, v: VehicleRecord, item) -> float | None:
        """`item`'s shift onto the one timeline, or None: held back until it is known."""
        line = self.timeline
        first = line.waiting(v.name) == 0
        shift = line.place(v.name, item)
        if shift is None and first:
            d = line.clock_disagreement(v.name, line.clocks[v.name].newest, self.clock())
            why = f"its clock reads {d:+.2f} s against {line.ref}'s" if d is not None else "-"
            self.warn_once(f"hold-{v.name}", f"{v.name}: samples held back until SYSTEM_TIME puts it on "
                                             f"{line.ref}'s timeline ({why})", period=10.0)
            self.request_system_time(v)
        return shift

    def release(self, vehicles: dict) -> list[tuple[VehicleRecord, object, float]]:
        """Held frame samples that can go now: (vehicle, sample, shift), in arrival order."""
        line = self.timeline
        for key in line.expire(self.clock()):
            self.log(f"{key}: no SYSTEM_TIME within {line.grace:g} s: presumed to share "
                     f"{line.ref}'s world, its stamps are used as they are")
        by_name = {v.name: v for v in vehicles.values()}
        out = []
        for key, items, shift in line.release():
            v = by_name[key]
            for item in items:
                if item[0] == "clock":
                    line.seen(key, item[1] + shift, item[2])
                else:
                    out.append((v, item[1], shift))
            self.log(f"{key}: {len(items)} held samples released onto {line.ref}'s timeline "
                     f"({line.basis(key)}, shift {shift:+.3f} s)")
        return out

    # ------------------------------------------------------------------ SYSTEM_TIME
    def on_system_time(self, v: VehicleRecord, msg, now: float) -> None:
        line = self.timeline
        before = line.basis(v.name)
        old = line.system_time(v.name, msg.time_unix_usec, msg.time_boot_ms, now)
        off = line.offset(v.name)
        if off is None:
            self.warn_once(f"no-unix-{v.name}", f"{v.name}: SYSTEM_TIME without unix time: "
                                                f"its clock offset stays unknown", period=60.0)
            return
        if old is not None:
            self.log(f"{v.name}: clock offset changed by {off - old:+.3f} s (another clock)")
        if old is not None or line.basis(v.name) != before or not v.offset_logged:
            v.offset_logged = True
            shift = line.shift(v.name)
            if v.name == line.ref:
                where = "its clock is the reference timeline"
            elif shift is not None:
                where = f"mapped onto {line.ref}'s timeline by {shift:+.3f} s ({line.basis(v.name)})"
            else:
                where = f"waiting for {line.ref}'s SYSTEM_TIME"
            self.log(f"{v.name}: SYSTEM_TIME: booted at unix {off:.3f} s; {where}")

    def request_system_time(self, v: VehicleRecord, force: bool = False) -> None:
        now = self.clock()
        if not force and now - v.last_time_req < 1.0:
            return
        v.last_time_req = now
        self._command(v, tl.MAV_CMD_REQUEST_MESSAGE, MSG_SYSTEM_TIME)

    # ------------------------------------------------------------------ TIMESYNC
    def probe(self, vehicles: dict, now: float) -> None:
        """One TIMESYNC request to every vehicle; SYSTEM_TIME again for those still held back."""
        for v in vehicles.values():
            ts1 = v.probe.request(int(now * 1e9))
            self._send(v, tl.MAVLink_timesync_message(0, ts1))
            if v.last_heartbeat_wall is not None and self.timeline.waiting(v.name):
                self.request_system_time(v)

    def on_timesync(self, v: VehicleRecord, msg, now: float) -> bool:
        """True when `msg` answers our own probe (then it is not forwarded)."""
        rtt = v.probe.reply(msg.tc1, msg.ts1, int(now * 1e9))
        if rtt is None:
            return False
        if v.probe.count == 1 or now - v.last_rtt_log >= RTT_LOG_PERIOD:
            v.last_rtt_log = now
            self.log(f"{v.name}: TIMESYNC round trip {rtt * 1e3:.2f} ms "
                     f"(min {v.probe.rtt_min * 1e3:.2f} ms, {v.probe.count} probes)")
        return True
