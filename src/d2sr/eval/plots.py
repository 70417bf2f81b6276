"""Plots of the de-synchronization experiments (matplotlib, Agg; files written atomically)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from d2sr.atomic import atomic_file
from d2sr.eval.desync import FPS, SCENARIOS, SENSORS, TITLES, CellResult
from d2sr.sim.calibrate import BINS, SequenceStats
from d2sr.version import __version__

__all__ = [
    "calibration",
    "convergence_cdf",
    "fig9",
    "label_f1",
    "paired",
    "ratio_over_time",
    "save",
    "sensor_timeline",
]

#: The only Fig. 9 values the paper states in its text (Section VI-A): N = 2 at 15 fps, 29.7%.
PAPER_POINTS = {("stationary", 2, 15): 0.297}
LABELS = {"static": "static (no D2SR)", "d2sr": "d2sr (paper Alg. 1)", "oracle": "oracle (global)"}


def save(fig: Figure, path: Path) -> Path:
    """Write a figure to a temporary name and rename, so a killed run leaves no half-written PNG."""
    try:
        with atomic_file(path) as tmp:
            kind = path.suffix.lstrip(".").lower() or "png"
            meta = {"Software": f"d2sr {__version__}"} if kind == "png" else None  # recognised as d2sr's
            fig.savefig(tmp, dpi=110, bbox_inches="tight", format=kind, metadata=meta)
    finally:
        plt.close(fig)
    return path


def _label(name: str, default: str) -> str:
    return LABELS.get(name, f"{name} (ours, default)" if name == default else name)


def fig9(results: Sequence[CellResult], default: str, profile: str = "default") -> Figure:
    """Interference ratio against frame rate, one line per N, one panel per scenario and controller."""
    rows = [r for r in results if r.profile == profile]
    scenarios = [sc for sc in SCENARIOS if any(r.scenario == sc for r in rows)]
    controllers = list(dict.fromkeys(r.controller for r in rows))
    fig, axes = plt.subplots(
        len(scenarios),
        len(controllers),
        figsize=(3.4 * len(controllers), 3.0 * len(scenarios)),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    colours = plt.get_cmap("viridis")(np.linspace(0, 0.9, len(SENSORS)))
    for a, sc in enumerate(scenarios):
        for b, ctrl in enumerate(controllers):
            ax = axes[a, b]
            for n, colour in zip(SENSORS, colours, strict=True):
                pts = sorted(
                    (r.fps, r.whole, r.whole_ci)
                    for r in rows
                    if r.scenario == sc and r.controller == ctrl and r.sensors == n
                )
                if pts:
                    fs, ys, es = map(np.array, zip(*pts, strict=True))
                    ax.errorbar(
                        fs, ys, yerr=es, color=colour, marker="o", ms=3, lw=1.2, capsize=2, label=f"N={n}"
                    )
            if ctrl == "d2sr":
                for (psc, n, f), v in PAPER_POINTS.items():
                    if psc == sc:
                        ax.plot([f], [v], "r*", ms=11, label=f"paper, N={n}")
            ax.set_title(f"{TITLES[sc]}:\n{_label(ctrl, default)}", fontsize=8)
            ax.set_ylim(-0.02, 1.02)
            ax.set_xticks(FPS)
            ax.grid(alpha=0.3)
            if a == len(scenarios) - 1:
                ax.set_xlabel("frame rate (active frames per 1 s period)")
            if b == 0:
                ax.set_ylabel("interference ratio (whole run)")
    axes[0, -1].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"Interference ratio vs frame rate and sensors (paper Fig. 9), profile '{profile}'")
    return fig


def paired(results: Sequence[CellResult], default: str, profile: str = "default") -> Figure:
    """Whole-run ratio of the default against Algorithm 1 and against the oracle, one point per cell."""
    by = {(r.scenario, r.fps, r.sensors, r.controller): r for r in results if r.profile == profile}
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
    for ax, ref in zip(axes, ("d2sr", "oracle"), strict=True):
        for sc, marker in zip(SCENARIOS, "osv^D", strict=True):
            pts = [
                (by[k].whole, by[(k[0], k[1], k[2], default)].whole, by[k].slack)
                for k in by
                if k[3] == ref and k[0] == sc and (k[0], k[1], k[2], default) in by
            ]
            if not pts:
                continue
            x, y, slack = map(np.array, zip(*pts, strict=True))
            ax.scatter(x[slack], y[slack], marker=marker, c="tab:green", label=f"{sc}, slack")
            ax.scatter(x[~slack], y[~slack], marker=marker, c="tab:red", label=f"{sc}, oversubscribed")
        ax.plot([0, 1], [0, 1], "k--", lw=0.8, label="equal")
        if ref == "oracle":
            ax.plot([0, 1 / 1.5], [0, 1], "k:", lw=0.8, label="1.5 x oracle")
        ax.set_xlabel(f"{_label(ref, default)}: whole-run ratio")
        ax.set_ylabel(f"{_label(default, default)}: whole-run ratio")
        ax.set_xlim(-0.02, 1.02)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"Default controller against Algorithm 1 and the oracle, every cell, profile '{profile}'")
    return fig


def convergence_cdf(results: Sequence[CellResult], default: str) -> Figure:
    """Distribution of convergence time over replicas of the stationary slack cells, per controller."""
    fig, ax = plt.subplots(figsize=(6, 4))
    rows = [
        r
        for r in results
        if r.profile == "default" and r.scenario == "stationary" and r.slack and r.sensors > 1
    ]
    for ctrl in dict.fromkeys(r.controller for r in rows):
        conv = np.concatenate([np.array(r.converged) for r in rows if r.controller == ctrl])
        if conv.size == 0:
            continue
        x = np.sort(np.where(np.isfinite(conv), conv, np.inf))
        y = np.arange(1, x.size + 1) / x.size
        ax.step(x[np.isfinite(x)], y[np.isfinite(x)], where="post", label=_label(ctrl, default))
    ax.axvline(10, color="k", ls=":", lw=0.8, label="bar: median <= 10")
    ax.set_xlabel("periods until the 5-period interference ratio stays <= 5%")
    ax.set_ylabel("fraction of rooms")
    ax.set_title("Convergence, stationary rooms with slack (N >= 2)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def sensor_timeline(
    frames: np.ndarray,
    total: int,
    sensors: Sequence[int],
    periods: int,
    title: str,
    flagged: np.ndarray | None = None,
) -> Figure:
    """Each sensor's frames over time on its own period grid: clean, interfered, and idle slots
    (``frames``: sensors x slots, 0 idle, 1 clean, 2 interfered); ``flagged`` marks the detector's flags."""
    fig, axes = plt.subplots(
        len(sensors), 1, figsize=(9, 0.9 * len(sensors) + 0.8), sharex=True, squeeze=False
    )
    cmap = matplotlib.colors.ListedColormap(["#eeeeee", "#4c9f70", "#d1495b"])
    for ax, s in zip(axes[:, 0], sensors, strict=True):
        img = frames[s, : periods * total].reshape(periods, total).T
        ax.imshow(img, aspect="auto", cmap=cmap, vmin=0, vmax=2, interpolation="nearest")
        if flagged is not None:
            slot, per = np.nonzero(flagged[s, : periods * total].reshape(periods, total).T)
            ax.plot(per, slot, "k.", ms=2.5)
        ax.set_ylabel(f"sensor {s}\nslot", fontsize=8)
        ax.set_yticks([0, total - 1])
    legend = "green: clean frame, red: interfered frame, grey: laser idle"
    legend += ", dot: flagged by the detector" if flagged is not None else ""
    axes[-1, 0].set_xlabel(f"period (1 s)   {legend}")
    fig.suptitle(title, fontsize=10)
    return fig


def ratio_over_time(series: dict[str, np.ndarray], default: str, title: str) -> Figure:
    """Mean interference ratio per period, one line per controller."""
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for name, y in series.items():
        ax.plot(np.arange(y.size), y, label=_label(name, default), lw=1.5)
    ax.set_xlabel("period (1 s)")
    ax.set_ylabel("interfered / captured frames")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=10)
    return fig


def calibration(real: dict[str, SequenceStats], sim: SequenceStats) -> Figure:
    """Real vs simulated sensor statistics: zero fraction, flicker, lone dropouts, small holes, reliably
    returning pixels, temporal noise against range."""
    fig, ax = plt.subplots(1, 6, figsize=(24, 3.8))
    names = [*real, "simulated"]
    allst = [*real.values(), sim]
    colours = [f"C{i}" for i in range(len(real))] + ["k"]
    for a, key, title in (
        (ax[0], "zero_frac", "zero fraction per frame"),
        (ax[1], "flicker", "dropout flicker"),
        (ax[2], "pinholes", "lone dropouts per returning pixel"),
        (ax[3], "small_holes", "pixels of 2-10 pixel holes per returning pixel"),
        (ax[4], "reliable", "pixels returning in >= 90% of frames"),
    ):
        vals = [getattr(s, key) for s in allst]
        a.bar(names, vals, color=colours)
        mean = float(np.mean([getattr(s, key) for s in real.values()]))
        a.axhspan(0.8 * mean, 1.2 * mean, color="0.85", zorder=0, label="real mean +-20%")
        a.set_title(title, fontsize=9)
        a.legend(loc="lower right", fontsize=8)
    centres = (BINS[:-1] + BINS[1:]) / 2
    for (name, s), c in zip(zip(names, allst, strict=True), colours, strict=True):
        ax[5].plot(centres, s.noise * 1000, "o-", color=c, label=name)
    ax[5].set_xlabel("range (m)")
    ax[5].set_ylabel("per-pixel temporal sd (mm)")
    ax[5].set_title("range noise")
    ax[5].legend(fontsize=8)
    fig.tight_layout()
    return fig


def label_f1(results: dict[str, dict[str, dict[str, float]]]) -> Figure:
    """Mask F1 per case and labelling method (the bars: 0.85 simulated, 0.8 real)."""
    cases = list(results)
    methods = list(next(iter(results.values())))
    fig, ax = plt.subplots(figsize=(max(6, 1.3 * len(cases)), 3.8))
    width = 0.8 / len(methods)
    for k, m in enumerate(methods):
        ax.bar(np.arange(len(cases)) + k * width, [results[c][m]["f1"] for c in cases], width, label=m)
    ax.axhline(0.85, color="k", ls="--", lw=1, label="bar, simulated (0.85)")
    ax.axhline(0.80, color="k", ls=":", lw=1, label="bar, real (0.80)")
    ax.set_xticks(np.arange(len(cases)) + 0.4 - width / 2, cases)
    ax.set_ylabel("mask F1")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, ncol=2, loc="lower left")
    fig.tight_layout()
    return fig
