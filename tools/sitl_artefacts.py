"""What a failing test leaves behind: its world's tlog and a plot of the vehicles' tracks.

The plot has two panels: the map (north up, east right, world NED m from the world origin):
each vehicle's true track (SIM_STATE) solid and its own estimate (GLOBAL_POSITION_INT) dashed,
start and end marked; and height above the origin over sim time. matplotlib (the ``plot``
extra) draws it; without it the tlog alone is left and the report says so.
"""
from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from common import geo


def read_tracks(tlog: Path, origin: tuple[float, float, float]) -> dict[int, dict[str, list]]:
    """sysid -> {"truth": [(n, e)], "estimate": [(n, e)], "height": [(t s, h m)]} from a tlog."""
    from pymavlink import mavutil
    tracks: dict[int, dict[str, list]] = defaultdict(lambda: {"truth": [], "estimate": [], "height": []})
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    try:
        while True:
            m = log.recv_match(type=["SIM_STATE", "GLOBAL_POSITION_INT"])
            if m is None:
                break
            tr = tracks[m.get_srcSystem()]
            if m.get_type() == "SIM_STATE":
                n, e, _ = geo.lla_to_ned(origin, m.lat_int / 1e7, m.lon_int / 1e7, m.alt)
                tr["truth"].append((n, e))
            else:
                n, e, d = geo.lla_to_ned(origin, m.lat / 1e7, m.lon / 1e7, m.alt / 1000.0)
                tr["estimate"].append((n, e))
                tr["height"].append((m.time_boot_ms / 1000.0, -d))
    finally:
        log.close()
    return dict(tracks)


MIN_SPAN_M = 10.0       # the map shows at least this much (a hover's centimetres are no track)


def _at_least(ax, span: float) -> None:
    for get, put in ((ax.get_xlim, ax.set_xlim), (ax.get_ylim, ax.set_ylim)):
        lo, hi = get()
        if hi - lo < span:
            mid = 0.5 * (lo + hi)
            put(mid - span / 2, mid + span / 2)


def plot_tracks(tlog: Path, png: Path, origin: tuple[float, float, float], title: str = "") -> Path:
    """Draw the tlog's tracks into `png`; ImportError without matplotlib."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    tracks = read_tracks(tlog, origin)
    fig, (ax_map, ax_h) = plt.subplots(1, 2, figsize=(11, 5), gridspec_kw={"width_ratios": [1.2, 1]})
    for sysid, tr in sorted(tracks.items()):
        colour = f"C{(sysid - 1) % 10}"
        for key, style in (("truth", "-"), ("estimate", "--")):
            pts = tr[key]
            if pts:
                n, e = zip(*pts)
                ax_map.plot(e, n, style, color=colour, lw=1.2 if key == "truth" else 0.8,
                            label=f"sysid {sysid} {key}")
                if key == "truth":
                    ax_map.plot(e[0], n[0], "o", color=colour)
                    ax_map.plot(e[-1], n[-1], "x", color=colour, ms=9)
        if tr["height"]:
            t, h = zip(*tr["height"])
            ax_h.plot(t, h, color=colour, label=f"sysid {sysid}")
    _at_least(ax_map, MIN_SPAN_M)
    ax_map.set_xlabel("east (m)")
    ax_map.set_ylabel("north (m)")
    ax_map.set_aspect("equal", adjustable="datalim")
    ax_map.grid(alpha=0.3)
    ax_map.legend(fontsize=7, loc="best")
    ax_map.set_title("tracks (o start, x end)")
    ax_h.set_xlabel("sim time (s)")
    ax_h.set_ylabel("height above origin (m)")
    ax_h.grid(alpha=0.3)
    ax_h.set_title("height (estimate)")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return png


def failure_artefacts(tlog: Path, origin: tuple[float, float, float], title: str, extra: list[Path]) -> str:
    """Draw the plot beside the tlog; the report section's text (where each file is)."""
    lines = [f"towerlink tlog: {tlog}"]
    png = tlog.with_suffix(".png")
    try:
        plot_tracks(tlog, png, origin, title)
        lines.append(f"towerlink track plot: {png}")
    except ImportError:
        lines.append("towerlink track plot: not drawn (matplotlib is not installed: the 'plot' extra)")
    except Exception as exc:  # noqa: BLE001 - a broken plot must not hide the test's own failure
        lines.append(f"towerlink track plot: not drawn ({exc!r})")
    lines += [f"towerlink {p.name}: {p}" for p in extra if p.exists()]
    return "\n".join(lines)
