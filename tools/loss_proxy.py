"""A tiny UDP proxy that drops packets: a lossy radio link for tests and demos.

    proxy = LossProxy(listen_port, ("127.0.0.1", bridge_tower_port), loss=0.2, seed=1)
    proxy.start()         # a thread; the GCS talks to listen_port instead of the bridge
    ...
    proxy.stop()

Datagrams from the client side (whoever writes to listen_port; the latest writer
is the client) go to `upstream`; datagrams from upstream go back to the client.
Each datagram in each direction is dropped with probability `loss`, from a seeded
RNG, so a failing run can be replayed. Counters: passed/dropped per direction.
`spare(datagram) -> bool` names datagrams never dropped (nor drawn for): `towerlink fly`
spares TOWERLINK_LOCKSTEP in lockstep, the simulator's clock rather than radio traffic (a
lost ACK or TICK would cost the run half a second of wall time, its re-send).

As a command: python -m tools.loss_proxy LISTEN_PORT UPSTREAM_PORT [--loss 0.2] [--seed 1]
"""
from __future__ import annotations

import argparse
import random
import selectors
import socket
import threading


class LossProxy(threading.Thread):
    def __init__(self, listen_port: int, upstream: tuple[str, int], loss: float = 0.2,
                 seed: int = 1, host: str = "127.0.0.1", spare=None) -> None:
        super().__init__(daemon=True, name=f"loss-proxy:{listen_port}")
        if not 0.0 <= loss < 1.0:
            raise ValueError("loss must be in [0, 1)")
        self.loss = loss
        self.spare = spare
        self.rng = random.Random(seed)
        self.upstream = upstream
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind((host, listen_port))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind((host, 0))
        self.client: tuple[str, int] | None = None
        self.passed = {"up": 0, "down": 0}
        self.dropped = {"up": 0, "down": 0}
        self._halt = threading.Event()

    def _drop(self, way: str, data: bytes = b"") -> bool:
        if self.spare is not None and self.spare(data):
            return False
        if self.rng.random() < self.loss:
            self.dropped[way] += 1
            return True
        self.passed[way] += 1
        return False

    def run(self) -> None:
        sel = selectors.DefaultSelector()
        sel.register(self.front, selectors.EVENT_READ, "up")
        sel.register(self.back, selectors.EVENT_READ, "down")
        try:
            while not self._halt.is_set():
                for key, _ in sel.select(timeout=0.1):
                    try:
                        data, addr = key.fileobj.recvfrom(65535)
                    except OSError:
                        continue
                    if key.data == "up":
                        self.client = addr
                        if not self._drop("up", data):
                            self._sendto(self.back, data, self.upstream)
                    elif self.client is not None and not self._drop("down", data):
                        self._sendto(self.front, data, self.client)
        finally:
            sel.close()

    @staticmethod
    def _sendto(sock: socket.socket, data: bytes, addr) -> None:
        try:
            sock.sendto(data, addr)
        except OSError:
            pass  # nobody listening right now (e.g. the bridge restarting): a lost packet

    def stop(self) -> None:
        self._halt.set()
        if self.is_alive():
            self.join(2.0)
        self.front.close()
        self.back.close()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m tools.loss_proxy", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("listen_port", type=int)
    p.add_argument("upstream_port", type=int)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--loss", type=float, default=0.2)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    proxy = LossProxy(a.listen_port, (a.host, a.upstream_port), a.loss, a.seed, a.host)
    proxy.start()
    try:
        while proxy.is_alive():
            proxy.join(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        proxy.stop()
        print(f"passed {proxy.passed}, dropped {proxy.dropped}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
