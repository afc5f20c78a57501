"""The bridge's end-of-run counters (printed when `towerlink bridge` stops); the same counters
go out at 1 Hz as TOWERLINK_BRIDGE_STATUS per link (bridge.upkeep, bridge.codec)."""
from __future__ import annotations


def summary(links, vehicles: dict, timeline, node_frames, followers: dict, decode_errors: int,
            tower_drops: int, lockstep, held_next_frame: int = 0) -> str:
    """The bridge's end-of-run counters, one line per link and vehicle."""
    parts = []
    for link in links:
        st = link.stats
        parts.append(f"{link.name}: rx {st.rx_packets} tx {st.tx_packets} malformed {link.malformed} "
                     f"unroutable {st.unroutable} translated {st.translated} deferred {st.deferred} "
                     f"refused {st.refused} unsigned {st.unsigned} bad signature {st.bad_signature}")
    for v in vehicles.values():
        p = v.probe
        rtt = "-" if p.rtt is None else f"{p.rtt * 1e3:.2f} ms (min {p.rtt_min * 1e3:.2f} ms)"
        parts.append(f"{v.name}: timeline {timeline.basis(v.name)}; TIMESYNC round trip {rtt}; "
                     f"samples held back {timeline.held(v.name)}")
    nf = node_frames
    if nf.owners or nf.refused:
        parts.append(f"node frames: {', '.join(f'{c} by {o}' for c, o in sorted(nf.owners.items())) or '-'}; "
                     f"refused {sum(nf.refused.values())}")
    ticks = " ".join(f"{vehicles[d].name}:{f.ticks}" for d, (f, _r) in followers.items())
    parts.append(f"follow ticks {ticks or 0}; decode errors {decode_errors}; "
                 f"tower telemetry dropped (no transform) {tower_drops}")
    if lockstep is not None:
        parts.append(f"lockstep: {lockstep.barriers} barriers, last at {lockstep.sim_now:.3f} s sim; "
                     f"tower {'joined' if lockstep.tower_joined else 'not joined'}; "
                     f"TICKs sent to the tower again {lockstep.tick_resends}; "
                     f"the world's TICKs answered again {lockstep.tick_resends_seen}"
                     + (f"; pipelined: {held_next_frame} vehicle packets handled a whole frame at a time"
                        if lockstep.lag else ""))
        if lockstep.nodes is not None:
            parts.append(lockstep.nodes.summary())
    return "\n".join(parts)
