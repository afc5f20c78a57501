"""The process side of a test's world run as a subprocess (tools.sitl_process starts it):

    python -m tools.sitl_child '{"spec": {...marker keywords...}, "udp": [...], "tcp": [...],
                                 "record_to": "udpout:127.0.0.1:P", "workdir": "..."}'

It builds the same warmed-up world as the in-process fixture (tools.sitl_world), prints READY
once every endpoint is bound and runs until SIGTERM. Exit 3 (after ADDRESS-IN-USE) when a port
was taken in the meantime: the parent tries again on new ports.
"""
from __future__ import annotations

import asyncio
import json
import signal
import sys
from pathlib import Path

from tools.sitl_spec import make_spec
from tools.sitl_world import Ports, address_in_use, build_world, run_closing

EXIT_ADDRESS_IN_USE = 3


def main(argv: list[str] | None = None) -> int:
    cfg = json.loads((argv if argv is not None else sys.argv[1:])[0])
    spec = make_spec(cfg["spec"])
    world = build_world(spec, Ports(tuple(cfg["udp"]), tuple(cfg["tcp"])), cfg.get("record_to"),
                        Path(cfg["workdir"]))
    stopping = []

    def on_term(*_a) -> None:
        stopping.append(True)
        world.request_stop()

    def started() -> None:
        print("READY", flush=True)
        if stopping:                 # SIGTERM came while the sockets were being bound
            world.request_stop()

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    try:
        asyncio.run(run_closing(world, started))
    except OSError as exc:
        if address_in_use(exc):
            print(f"ADDRESS-IN-USE {exc}", flush=True)
            return EXIT_ADDRESS_IN_USE
        raise
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
