"""pymavlink connection strings: ``KIND:HOST:PORT`` -> (kind, host, port).

  udpin:HOST:PORT    listen for UDP (``udp:`` is pymavlink's alias for it)
  udpout:HOST:PORT   send UDP to a listener
  tcp:HOST:PORT      connect to a TCP server (ArduPilot SITL's 5760)
  tcpin:HOST:PORT    serve TCP

Each program accepts the kinds it implements (`kinds`) and fills an empty host with its
own default. Errors are ValueError with the string quoted and the accepted forms listed.
"""
from __future__ import annotations

KINDS = ("udpin", "udpout", "tcp", "tcpin")
ALIASES = {"udp": "udpin"}


def parse_connection(url: str, kinds: tuple[str, ...] = KINDS,
                     default_host: str = "127.0.0.1") -> tuple[str, str, int]:
    """'udpin:127.0.0.1:14560' -> ('udpin', '127.0.0.1', 14560); raises ValueError."""
    forms = ", ".join(f"{k}:HOST:PORT" for k in kinds)
    try:
        kind, rest = str(url).strip().split(":", 1)
        host, port = rest.rsplit(":", 1)
        port_n = int(port)
    except ValueError:
        raise ValueError(f"bad connection string {url!r}; use {forms}") from None
    kind = ALIASES.get(kind.lower(), kind.lower())
    if kind not in kinds:
        raise ValueError(f"unsupported connection kind {kind!r} in {url!r}; use {forms}")
    if not 0 < port_n < 65536:
        raise ValueError(f"bad port in {url!r}; ports are 1 to 65535")
    return kind, host or default_host, port_n
