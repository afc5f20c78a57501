"""The onboard logs and the telemetry bytes of a fixed, seeded in-process run are the same,
byte for byte, as the ones recorded before the log sampler and the telemetry builders were
made faster (tests/data/log_telemetry_golden.json, written by this scenario on the tree before
that change).

The scenario: the default world (one drone, one rover), start time fixed, every SR0_* stream
group at 10 Hz, PID_TUNING on every axis, ATTITUDE_TARGET asked for; both vehicles armed in
GUIDED, the drone takes off and flies to a point, the rover drives to it (tools/bench_default_world.py's
flight), then the drone lands and
disarms (ARM / EV / MODE / MSG records) while the rover goes on. Each vehicle's telemetry
(every datagram its udpout endpoint sends) and each log file are hashed.

Regenerate (only when a change is meant to alter log or telemetry bytes, and say so):
  PYTHONPATH=. python tests/test_log_telemetry_bytes.py > tests/data/log_telemetry_golden.json
"""
from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

GOLDEN = Path(__file__).parent / "data" / "log_telemetry_golden.json"
START_AT = 1_700_000_000.25          # unix s of sim t = 0 (GPS records, SYSTEM_TIME)


class _Recorder:
    """Stands in for a udpout endpoint's transport: keeps every datagram."""

    def __init__(self) -> None:
        self.data: list[bytes] = []

    def sendto(self, buf: bytes, addr=None) -> None:
        self.data.append(bytes(buf))

    def close(self) -> None:
        pass


def run_scenario(state_dir: str) -> dict[str, str]:
    """{"<vehicle> telemetry" / "<vehicle> log <name>": sha256 hex} of the scenario (module doc)."""
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from tools.bench_default_world import _fly as fly
    from vehicle.autopilot import modes
    from vehicle.world import World, WorldConfig
    w = World(WorldConfig(drones=1, rovers=1, seed=7, state_dir=state_dir, tcp_base=None, udp_base=None,
                          outs=["udpout:127.0.0.1:9"], start_at=START_AT))
    recorders = []
    for v in w.vehicles:
        rec = _Recorder()
        for ep in v.link.endpoints:
            ep.transport = rec
            ep.addr = ("127.0.0.1", 9)
        recorders.append(rec)
        ps = v.ap.params
        for g in v.link.telemetry.groups:
            ps.set(g, 10, save=False)
        ps.set("GCS_PID_MASK", 15 if v.kind == "copter" else 3, save=False)
        v.link.streams.rebuild()
        v.link.streams._set_interval(mav.MAVLINK_MSG_ID_ATTITUDE_TARGET, 100_000)
    fly(w)                              # both armed in GUIDED, on their way to a point 20 m off
    drone = w.vehicles[0].ap
    w.run_for(8.0)
    drone.set_mode(modes.LAND)
    w.run_for(12.0)
    for v in w.vehicles:
        v.link.close()
    w.logs.close()
    out = {}
    for v, rec in zip(w.vehicles, recorders):
        name = f"{v.kind}{v.ap.sysid}"
        out[f"{name} telemetry"] = hashlib.sha256(b"".join(rec.data)).hexdigest()
        out[f"{name} datagrams"] = str(len(rec.data))
    for f in sorted(Path(state_dir).glob("vehicles/*/logs/*.BIN")):
        out[f"log {f.parent.parent.name}/{f.name}"] = hashlib.sha256(f.read_bytes()).hexdigest()
        out[f"log {f.parent.parent.name}/{f.name} bytes"] = str(f.stat().st_size)
    return out


def test_logs_and_telemetry_bytes_unchanged(tmp_path):
    got = run_scenario(str(tmp_path / "state"))
    want = json.loads(GOLDEN.read_text())
    assert any(k.startswith("log ") for k in got), "the scenario wrote no log"
    assert got == want


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        json.dump(run_scenario(tmp + "/state"), sys.stdout, indent=1, sort_keys=True)
        print()
