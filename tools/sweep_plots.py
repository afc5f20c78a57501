"""The sweep's plots (matplotlib, PNG): one row per factor, a panel per figure.

sweep.png: for each factor that varies, its levels on x and, left to right, the rover's follow
error RMS (m), the wobble RMS of the followed frame (m), every goal's reach-time ratio (reach
time / minimum time, 1 = as fast as the limits allow), when any run had a failsafe the sim
seconds from its fault to the first failsafe (failsafe_s), and the failure rate. Each run is a
dot (failed runs as crosses), the level's mean a bar.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

PANELS = (("follow_rms", "follow error RMS (m)"), ("wobble_rms", "wobble RMS, followed frame (m)"),
          ("ratios", "goal reach-time ratio"), ("fail", "failure rate"))
FAILSAFE_PANEL = ("failsafe_s", "fault -> first failsafe (sim s)")


def _levels(rows: list[Mapping[str, Any]], factor: str) -> list[Any]:
    levels = list(dict.fromkeys(r.get(factor) for r in rows))
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in levels):
        levels.sort()
    return levels


def _ratios(r: Mapping[str, Any]) -> list[float]:
    return [float(v) for k, v in r.items()
            if k.startswith("goals.") and k.endswith(".ratio") and isinstance(v, (int, float))]


def plot_sweep(rows: list[Mapping[str, Any]], factors: list[str], path: Path, title: str = "") -> Path:
    """Draw sweep.png (see the module doc); returns its path."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    from tools.sweep_grid import format_value

    factors = factors or ["seed"]
    panels = PANELS
    if any(isinstance(r.get(FAILSAFE_PANEL[0]), (int, float)) for r in rows):
        panels = (*PANELS[:-1], FAILSAFE_PANEL, PANELS[-1])
    fig, axes = plt.subplots(len(factors), len(panels), figsize=(4.2 * len(panels), 3.0 * len(factors) + 0.6),
                             squeeze=False)
    rng = np.random.default_rng(0)          # jitter only; the same picture every time
    for i, f in enumerate(factors):
        levels = _levels(rows, f)
        labels = [format_value(v) if v is not None else "-" for v in levels]
        for j, (key, name) in enumerate(panels):
            ax = axes[i][j]
            for x, level in enumerate(levels):
                rs = [r for r in rows if r.get(f) == level]
                if key == "fail":
                    rate = sum(not r.get("pass") for r in rs) / len(rs) if rs else 0.0
                    ax.bar(x, rate, color="tab:red" if rate else "tab:green", width=0.6)
                    ax.text(x, rate, f"{sum(not r.get('pass') for r in rs)}/{len(rs)}",
                            ha="center", va="bottom", fontsize=8)
                    continue
                pts = [(v, bool(r.get("pass"))) for r in rs
                       for v in (_ratios(r) if key == "ratios" else [r.get(key)])
                       if isinstance(v, (int, float))]
                if not pts:
                    continue
                ys = np.array([p[0] for p in pts], float)
                ok = np.array([p[1] for p in pts])
                xs = x + rng.uniform(-0.15, 0.15, ys.size)
                ax.scatter(xs[ok], ys[ok], s=14, color="tab:blue", alpha=0.7)
                ax.scatter(xs[~ok], ys[~ok], s=22, color="tab:red", marker="x")
                ax.hlines(ys.mean(), x - 0.3, x + 0.3, color="black", lw=2)
            if key == "fail":
                ax.set_ylim(0, 1.1)
            if key == "ratios":
                ax.axhline(1.0, color="grey", lw=0.8, ls="--")
            ax.set_xticks(range(len(levels)), labels, rotation=20 if max(map(len, labels or [""])) > 6 else 0)
            ax.set_xlim(-0.6, len(levels) - 0.4)
            ax.grid(axis="y", alpha=0.3)
            if i == 0:
                ax.set_title(name, fontsize=10)
            if j == 0:
                ax.set_ylabel(f, fontsize=10, fontweight="bold")
    fig.suptitle(title or f"sweep: {len(rows)} runs (dots: runs, x: failed, bar: mean)", fontsize=11)
    fig.tight_layout()
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=90)
    plt.close(fig)
    tmp.replace(path)
    return path
