"""The world on another host ("Across machines"): `towerlink fly --world-host`.

`towerlink fly` normally starts the world, the bridge and the tower on 127.0.0.1. With
`--world-host ADDR` the world (`towerlink sitl`) runs on another host, as roslaunch's
<machine> runs a node elsewhere; the bridge, the tower and the launcher's monitor stay here:

  this host (B)                                 world host (A, ADDR)
  fly's monitor  <-- telemetry (--out) -------  towerlink sitl
  towerlink bridge  -- udpout:ADDR:PORT ----->  vehicle endpoints, udpin:0.0.0.0:PORT
  towerlink tower   (127.0.0.1, to the bridge)

The world listens on every interface of its host (0.0.0.0, so ADDR may be any of its
addresses, or a name behind NAT) and pushes its telemetry to this host's address on the route
to ADDR (`LOCAL`, found by asking the kernel which source address it would use; give
`--local-host` when the world reaches this host by another address, e.g. through NAT).
With --lockstep the handshake runs over those same links, so the figures do not depend on the
link's latency either.

How the world is started there (`--world-cmd-prefix`):
  "ip netns exec A", "sudo -u sim", ...   the world's argv is appended word by word and run
                                          with this interpreter (same filesystem)
  "ssh -tt hostA"                         ssh: the world's command goes as one shell-quoted
                                          string, run as `towerlink sitl ...` from the remote
                                          PATH; -tt so that stopping ssh stops the world
  (none)                                  attach: fly prints the `towerlink sitl` command to
                                          start on the world host, then waits for its telemetry

The world's ports are picked free on this host and assumed free on the world host.
"""
from __future__ import annotations

import argparse
import shlex
import socket
from dataclasses import dataclass

WORLD_BIND = "0.0.0.0"      # where a remote world's endpoints listen: every interface of its host


@dataclass(frozen=True)
class WorldHost:
    """Where the world runs and how both sides reach each other (IPv4 addresses or names)."""

    addr: str                       # the world's host as this host reaches it (the bridge's udpout target)
    local: str                      # this host as the world reaches it (the world's --out target)
    prefix: tuple[str, ...] = ()    # runs a command on the world's host; () = the user starts it (attach)

    @property
    def bind(self) -> str:
        return WORLD_BIND

    @property
    def via_ssh(self) -> bool:
        return bool(self.prefix) and self.prefix[0].rsplit("/", 1)[-1] == "ssh"

    @property
    def attach(self) -> bool:
        return not self.prefix

    def command(self, local_argv: list[str]) -> list[str]:
        """The argv that starts the world there, from the one that would start it here
        (`python -m tools.cli sitl ...`): as is after an exec-style prefix; through ssh as
        one shell-quoted `towerlink sitl ...` string (ssh hands its words to the remote shell);
        for attach, `towerlink sitl ...` as the user types it there."""
        if self.attach:
            return portable(local_argv)         # printed for the user to run there
        if not self.via_ssh:
            return [*self.prefix, *local_argv]
        return [*self.prefix, shlex.join(portable(local_argv))]

    def describe(self) -> str:
        how = ("started by you (attach)" if self.attach else f"started with {shlex.join(self.prefix)!r}")
        return f"world on {self.addr} ({how}), listening on {self.bind}, telemetry to {self.local}"


def portable(local_argv: list[str]) -> list[str]:
    """`python -m tools.cli ARGS` -> `towerlink ARGS` (the console script on the other host)."""
    if len(local_argv) >= 3 and local_argv[1:3] == ["-m", "tools.cli"]:
        return ["towerlink", *local_argv[3:]]
    return list(local_argv)


def local_address_towards(addr: str, port: int = 9) -> str:
    """This host's source address on its route to `addr` (what the world sees as the sender).

    A UDP connect() sends nothing; it only makes the kernel choose the route and source
    address. Raises OSError (e.g. socket.gaierror) when `addr` cannot be resolved or routed."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect((addr, port))
        return s.getsockname()[0]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    g = parser.add_argument_group(
        "world on another host",
        'e.g. towerlink fly --lockstep --world-host 10.0.0.2 --world-cmd-prefix "ssh -tt sim-box"')
    g.add_argument("--world-host", metavar="ADDR", default=None,
                   help="run the world (towerlink sitl) on the host at ADDR instead of 127.0.0.1; it listens on "
                        "0.0.0.0 there and pushes telemetry to this host; bridge, tower and monitor stay here")
    g.add_argument("--world-cmd-prefix", metavar="CMD", default=None,
                   help='how to start the world there, e.g. "ip netns exec simA" or "ssh -tt sim-box" (ssh: '
                        "`towerlink` must be on the remote PATH); without it fly prints the world's command "
                        "for you to start on ADDR and waits for it")
    g.add_argument("--local-host", metavar="ADDR", default=None,
                   help="this host's address as the world host reaches it (default: the source address of "
                        "this host's route to --world-host)")


def from_args(args: argparse.Namespace) -> WorldHost | None:
    """The WorldHost the options ask for; None when the world runs here. ValueError on a bad mix."""
    addr = getattr(args, "world_host", None)
    prefix = getattr(args, "world_cmd_prefix", None)
    local = getattr(args, "local_host", None)
    if not addr:
        if prefix or local:
            raise ValueError("--world-cmd-prefix and --local-host need --world-host ADDR")
        return None
    if local is None:
        try:
            local = local_address_towards(addr)
        except OSError as exc:
            raise ValueError(f"--world-host {addr}: no route from this host ({exc})") from exc
    try:
        words = tuple(shlex.split(prefix or ""))
    except ValueError as exc:
        raise ValueError(f"--world-cmd-prefix {prefix!r}: {exc}") from exc
    return WorldHost(addr=addr, local=local, prefix=words)
