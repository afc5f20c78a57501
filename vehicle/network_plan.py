"""The network plan of a SITL world: which MAVLink network each vehicle is on, its system id
and its ports (pure: no sockets, no files; `towerlink sitl` refuses a plan that fails here).

MAVLink gives a network 255 system ids; 255 is what GCSs use (MAVProxy, Mission Planner), so
a network here holds at most MAX_GROUP = 254 vehicles. A world of N vehicles is cut into
groups ("networks") of `group_size` consecutive vehicles (default 254, fewer when
--sysid-base is above 1):

  group of vehicle i      g = i // group_size
  sysid of vehicle i      sysid_base + i % group_size    (1..N for N <= 254, as before)
  --out HOST:P            group g pushes to HOST:P+g, so no link ever carries two
                          vehicles with one sysid (a GCS on 14550 sees network 0,
                          one on 14551 network 1, ...)

Ports (one namespace: a TCP and a UDP port with the same number count as a collision,
since `tcp:...:14560` and `udpout:...:14560` are too easy to mix up):

  stride 10 (ArduPilot SITL's instance spacing: 5760 + 10 i, 14560 + 10 i) when every block
  fits (no overlap, nothing above 65535); otherwise stride 1, a dense block
  (5760 + i, 14560 + i); if even that does not fit, the world is refused. With the default
  bases the stride is 10 up to 880 vehicles and 1 from 881 to 8800; more needs other bases
  (or --tcp-base 0 / --udp-base 0).

Refused, with a message naming the options involved (PlanError): a sysid used twice in one
network or on one udpout target, a port used twice, a port block overlapping another (the
TCP block, the UDP block, the per-network --out ports on a local host), ports above 65535,
--endpoint/--sysid for a vehicle that does not exist, a listening --out shared by vehicles.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

MAX_GROUP = 254          # vehicles (sysids) per MAVLink network; 255 is left to GCSs
MAX_SYSID = 255          # SYSID_THISMAV's range is 1..255
STRIDE = 10              # ArduPilot SITL: instance i serves 5760 + 10 i
MAX_PORT = 65535
LOCAL_HOSTS = {"127.0.0.1", "localhost", "0.0.0.0", "", "::1"}

RULE = ("vehicle i: network g = i // GROUP_SIZE, sysid SYSID_BASE + i % GROUP_SIZE; "
        "TCP TCP_BASE + 10 i and UDP UDP_BASE + 10 i while both blocks fit apart below 65536, "
        "else TCP_BASE + i and UDP_BASE + i; --out HOST:P becomes HOST:P+g for network g")


class PlanError(ValueError):
    """A world that cannot be planned; the message says which options clash and how."""


@dataclass(frozen=True)
class VehiclePlan:
    index: int               # 0.. over the world, drones first
    kind: str                # "copter" | "rover"
    kind_index: int          # j of drone<j> / rover<j>
    group: int
    sysid: int
    tcp: int | None          # default TCP port, None when none (or replaced by --endpoint)
    udp: int | None
    endpoints: tuple[str, ...]   # every endpoint spec of this vehicle, --out included

    def as_dict(self) -> dict:
        return {"index": self.index, "kind": self.kind, "name": f"{_name(self.kind)}{self.kind_index}",
                "group": self.group, "sysid": self.sysid, "tcp": self.tcp, "udp": self.udp,
                "endpoints": list(self.endpoints)}


@dataclass(frozen=True)
class GroupPlan:
    group: int
    first: int               # vehicle indices first..last
    last: int
    outs: tuple[str, ...]    # this network's --out endpoints


@dataclass(frozen=True)
class NetworkPlan:
    vehicles: tuple[VehiclePlan, ...]
    groups: tuple[GroupPlan, ...]
    group_size: int
    stride: int

    def as_dict(self) -> dict:
        """JSON-ready: what tools read (STATE_DIR/network_plan.json, --plan-out FILE)."""
        return {"version": 1, "rule": RULE, "group_size": self.group_size, "stride": self.stride,
                "groups": [{"group": g.group, "vehicles": [g.first, g.last],
                            "sysids": sorted({v.sysid for v in self.vehicles[g.first:g.last + 1]}),
                            "outs": list(g.outs)} for g in self.groups],
                "vehicles": [v.as_dict() for v in self.vehicles]}

    def summary(self) -> list[str]:
        """One line per network (printed at start)."""
        lines = []
        for g in self.groups:
            vs = self.vehicles[g.first:g.last + 1]
            ids = sorted(v.sysid for v in vs)
            line = (f"  network {g.group}: vehicles {g.first}-{g.last}, sysids {ids[0]}-{ids[-1]}"
                    f"{_block(', tcp', [v.tcp for v in vs])}{_block(', udp', [v.udp for v in vs])}")
            if g.outs:
                line += ", out " + " ".join(g.outs)
            lines.append(line)
        return lines

    def with_sysids(self, sysids: Sequence[int]) -> "NetworkPlan":
        """The plan with the sysids the vehicles actually booted with (a saved SYSID_THISMAV
        wins over the plan's); PlanError if that puts one sysid twice on a link."""
        vs = tuple(VehiclePlan(v.index, v.kind, v.kind_index, v.group, int(s), v.tcp, v.udp, v.endpoints)
                   for v, s in zip(self.vehicles, sysids))
        _check_links(vs, saved=True)
        return NetworkPlan(vs, self.groups, self.group_size, self.stride)


def _name(kind: str) -> str:
    return "drone" if kind == "copter" else "rover"


def _block(label: str, ports: list[int | None]) -> str:
    ps = [p for p in ports if p is not None]
    if not ps:
        return ""
    step = f" step {ps[1] - ps[0]}" if len(ps) > 1 else ""
    return f"{label} {ps[0]}-{ps[-1]}{step}" if len(ps) > 1 else f"{label} {ps[0]}"


def _host(h: str) -> str:
    h = h.lower()
    return "127.0.0.1" if h in ("localhost", "::1") else h


def _parse(spec: str) -> tuple[str, str, int]:
    from common.mavlink.endpoints import parse_connection
    try:
        return parse_connection(spec, kinds=("udpin", "udpout", "tcpin"), default_host="0.0.0.0")
    except ValueError as e:
        raise PlanError(f"{spec}: {e}") from None


def _stride(n: int, blocks: list[tuple[str, int]]) -> int:
    """STRIDE if every block of n ports at STRIDE fits apart below MAX_PORT, else 1; PlanError
    naming the clash when even dense blocks do not fit."""
    for stride in (STRIDE, 1):
        spans = [(f"{name} (--{name.lower()}-base {base})", base, base + stride * (n - 1)) for name, base in blocks]
        problem = None
        for name, lo, hi in spans:
            if hi > MAX_PORT:
                problem = f"{name} ports {lo}-{hi} for {n} vehicles pass {MAX_PORT}"
        for a in range(len(spans)):
            for b in range(a + 1, len(spans)):
                (na, la, ha), (nb, lb, hb) = spans[a], spans[b]
                if la <= hb and lb <= ha:
                    problem = (f"{na} ports {la}-{ha} for {n} vehicles overlap {nb} ports {lb}-{hb}")
        if problem is None:
            return stride
    raise PlanError(f"{problem} (even at one port per vehicle); move a base (--tcp-base, --udp-base) "
                    f"or turn one block off with 0")


def plan(drones: int, rovers: int, *, tcp_base: int | None = 5760, udp_base: int | None = 14560,
         host: str = "127.0.0.1", outs: Sequence[str] = (), endpoints: Mapping[int, Sequence[str]] | None = None,
         sysid_base: int = 1, sysids: Mapping[int, int] | None = None,
         group_size: int | None = None) -> NetworkPlan:
    """Plan a world of `drones` then `rovers` (see the module docstring for the rule).
    `endpoints` {i: [spec]} replaces vehicle i's default TCP/UDP ports; `sysids` {i: id}
    gives vehicle i an explicit sysid. Raises PlanError."""
    endpoints = dict(endpoints or {})
    sysids = dict(sysids or {})
    n = drones + rovers
    if drones < 0 or rovers < 0 or n < 1:
        raise PlanError("need at least one vehicle")
    if not 1 <= sysid_base <= MAX_GROUP:
        raise PlanError(f"--sysid-base {sysid_base}: must be 1..{MAX_GROUP}")
    room = MAX_GROUP - sysid_base + 1
    if group_size is None:
        group_size = room
    if not 1 <= group_size <= room:
        raise PlanError(f"--group-size {group_size}: must be 1..{room} (sysids {sysid_base}..{MAX_GROUP}; "
                        f"{MAX_SYSID} is left to ground stations)")
    for i in list(endpoints) + list(sysids):
        if not 0 <= i < n:
            raise PlanError(f"vehicle {i} does not exist: there are {n} vehicles (0..{n - 1})")
    for i, s in sysids.items():
        if not 1 <= s <= MAX_SYSID:
            raise PlanError(f"--sysid {i}={s}: a sysid is 1..{MAX_SYSID}")
    groups = (n + group_size - 1) // group_size

    blocks = [(name, base) for name, base in (("TCP", tcp_base), ("UDP", udp_base)) if base]
    for name, base in blocks:
        if not 1 <= base <= MAX_PORT:
            raise PlanError(f"--{name.lower()}-base {base}: must be 1..{MAX_PORT} (0: none)")
    stride = _stride(n, blocks)

    # --out: one port per network, checked against the blocks when it is on this machine
    out_specs: list[tuple[str, str, int]] = [_parse(s) for s in outs]
    for kind, h, p in out_specs:
        spec = f"{kind}:{h}:{p}"
        if kind != "udpout" and n > 1:
            raise PlanError(f"--out {spec}: a listening endpoint cannot be shared by {n} vehicles; "
                            f"give each its own with --endpoint I={kind}:HOST:PORT")
        if p + groups - 1 > MAX_PORT:
            raise PlanError(f"--out {spec}: {groups} networks need ports {p}-{p + groups - 1}, past {MAX_PORT}")
        if _host(h) in LOCAL_HOSTS or _host(h) == _host(host):
            for name, base in blocks:
                hi = base + stride * (n - 1)
                if p <= hi and base <= p + groups - 1:
                    rng = f"{p}-{p + groups - 1}" if groups > 1 else f"{p}"
                    raise PlanError(f"--out {spec}: port {rng} (one per network) overlaps the {name} "
                                    f"ports {base}-{hi} of the vehicles; use another --out port")

    vehicles = []
    taken: dict[int, str] = {}           # port -> who: every port bound here or aimed at locally

    def take(port: int, who: str) -> None:
        if port in taken:
            raise PlanError(f"port {port} used twice: {taken[port]} and {who}")
        taken[port] = who

    for i in range(n):
        kind, j = ("copter", i) if i < drones else ("rover", i - drones)
        g = i // group_size
        sid = sysids.get(i, sysid_base + i % group_size)
        tcp = udp = None
        if i in endpoints:
            eps = list(endpoints[i])
            for spec in eps:
                k, h, p = _parse(spec)
                if k != "udpout":           # a port this machine binds
                    take(p, f"--endpoint {i}={spec}")
        else:
            eps = []
            if tcp_base:
                tcp = tcp_base + stride * i
                take(tcp, f"vehicle {i}'s TCP port (--tcp-base {tcp_base})")
                eps.append(f"tcpin:{host}:{tcp}")
            if udp_base:
                udp = udp_base + stride * i
                take(udp, f"vehicle {i}'s UDP port (--udp-base {udp_base})")
                eps.append(f"udpin:{host}:{udp}")
        eps += [f"{k}:{h}:{p + g}" for k, h, p in out_specs]
        vehicles.append(VehiclePlan(i, kind, j, g, sid, tcp, udp, tuple(eps)))
    for k, h, p in out_specs:
        if _host(h) in LOCAL_HOSTS or _host(h) == _host(host):
            for g in range(groups):
                if p + g in taken:   # an --endpoint listening where a network's --out pushes
                    take(p + g, f"--out {k}:{h}:{p} (network {g})")
    gplans = tuple(GroupPlan(g, g * group_size, min(n, (g + 1) * group_size) - 1,
                             tuple(f"{k}:{h}:{p + g}" for k, h, p in out_specs)) for g in range(groups))
    vs = tuple(vehicles)
    _check_links(vs, saved=False)
    return NetworkPlan(vs, gplans, group_size, stride)


def _check_links(vehicles: Sequence[VehiclePlan], saved: bool) -> None:
    """No sysid twice in one network, nor on one udpout target (a link several vehicles share)."""
    how = "its saved SYSID_THISMAV" if saved else "--sysid"
    seen: dict[tuple, int] = {}
    for v in vehicles:
        keys = [("network", v.group)]
        for spec in v.endpoints:
            k, h, p = _parse(spec)
            if k == "udpout":
                keys.append(("udpout", f"{_host(h)}:{p}"))
        for key in keys:
            prev = seen.setdefault(key + (v.sysid,), v.index)
            if prev != v.index:
                where = f"network {key[1]}" if key[0] == "network" else f"the link to udpout:{key[1]}"
                raise PlanError(f"sysid {v.sysid} used twice in {where}: vehicles {prev} and {v.index} "
                                f"(check {how}; every vehicle on one link needs its own sysid)")
