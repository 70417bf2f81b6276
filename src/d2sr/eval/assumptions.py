"""The controllers across the assumptions a real deployment varies over (``d2sr desync grid``).

Our sweep's defaults (what counts as an overlapped frame, laser start-up, hit probability, detector
quality) are one point among many. This grid spans them: the share of a frame's time that must overlap
(5-50%), start-up slots (0-3), hit probability (0.5-1), detector recall (0.5-1) and false alarms (0-5%),
clock drift (0-200 ppm); for two sensors at every frame rate, and for three to five sensors with and
without slack (oversubscribed: N x (n + start-up) > 30). Every room meets every setting, and every
controller in a cell sees the same seed (paired): the difference between two controllers is theirs.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from d2sr.desync import TOTAL_FRAMES
from d2sr.eval.desync import Cell, run_cell
from d2sr.frames.overlap import MAX_WORKERS, processes
from d2sr.sim.timing import TimingSettings

__all__ = [
    "AXES",
    "ROOMS",
    "GridResult",
    "heatmap",
    "markdown",
    "oversubscribed",
    "run_grid",
    "settings",
    "summary",
]

#: Each assumption and the values the grid takes.
AXES: dict[str, tuple[float, ...]] = {
    "min_overlap": (0.05, 0.15, 0.3, 0.5),
    "setup": (0, 1, 2, 3),
    "hit_prob": (0.5, 0.75, 1.0),
    "recall": (0.5, 0.75, 0.9, 1.0),
    "false_alarm": (0.0, 0.01, 0.05),
    "drift_ppm": (0.0, 50.0, 200.0),
}
#: (sensors, frames per period): two sensors at every frame rate, then crowded rooms.
ROOMS: tuple[tuple[int, int], ...] = (
    *((2, f) for f in (4, 6, 8, 10, 12, 13, 14, 15, 16, 20, 25)),
    (3, 4), (3, 6), (3, 8), (3, 10), (3, 12),
    (4, 4), (4, 5), (4, 6), (4, 8),
    (5, 3), (5, 4), (5, 6),
)  # fmt: skip


def settings(count: int, seed: int = 0) -> list[dict[str, float]]:
    """``count`` joint settings of every axis: the sweep's own default first, the harshest corner second,
    then draws that use each axis value equally often (a Latin-hypercube design)."""
    out = [
        {
            "min_overlap": 0.3,
            "setup": 2,
            "hit_prob": 0.9,
            "recall": 0.9,
            "false_alarm": 0.01,
            "drift_ppm": 50.0,
        },
        {
            "min_overlap": 0.05,
            "setup": 3,
            "hit_prob": 0.5,
            "recall": 0.5,
            "false_alarm": 0.05,
            "drift_ppm": 200.0,
        },
    ]
    rng = np.random.default_rng(seed)
    rest = max(0, count - len(out))
    columns = {k: rng.permutation(np.resize(np.array(v, float), rest)) for k, v in AXES.items()}
    for i in range(rest):
        out.append({k: float(columns[k][i]) for k in AXES})
    return [{**s, "setup": int(s["setup"])} for s in out[:count]]


def oversubscribed(sensors: int, fps: int, setup: float) -> bool:
    """More laser time asked for than a period holds: N x (n + start-up) > slots."""
    return sensors * (fps + setup) > TOTAL_FRAMES


@dataclass(frozen=True)
class GridResult:
    sensors: int
    fps: int
    setting: int
    controller: str
    whole: float  # interfered / captured frames over the run
    steady: float  # the same over its second half
    converged_median: float  # periods until <= 5% for good (inf: never)
    per_replica: tuple[float, ...]


def _run(job: tuple[int, int, int, dict[str, float], str, int, float]) -> GridResult:
    n, fps, k, setting, controller, replicas, seconds = job
    cfg = TimingSettings.make(active_frames=fps, **setting)
    cell = Cell("stationary", fps, n, controller, "grid", replicas, seconds, seed=1000 + k)
    r = run_cell(cell, cfg)
    return GridResult(n, fps, k, controller, r.whole, r.steady, r.converged_median, r.per_replica)


def run_grid(
    controllers: Sequence[str],
    count: int = 12,
    replicas: int = 20,
    seconds: float = 60.0,
    rooms: Sequence[tuple[int, int]] = ROOMS,
    jobs: int | None = None,
    progress: Callable[[], None] | None = None,
) -> tuple[list[dict[str, float]], list[GridResult]]:
    """Every controller in every (room, setting) cell; the oracle only where the period is oversubscribed
    (its reference there)."""
    sets = settings(count)
    work = [
        (n, f, k, s, c, replicas, seconds)
        for n, f in rooms
        for k, s in enumerate(sets)
        for c in controllers
        if c != "oracle" or oversubscribed(n, f, s["setup"])
    ]
    work.sort(key=lambda j: -j[0] * (j[1] + 3))  # largest first, so workers finish together
    results = []
    with processes(jobs or min(os.cpu_count() or 1, MAX_WORKERS)) as pool:
        for r in pool.map(_run, work, chunksize=2):
            results.append(r)
            if progress:
                progress()
    return sets, results


def summary(
    sets: list[dict[str, float]], results: list[GridResult], default: str, reference: str = "d2sr"
) -> dict[str, Any]:
    """Per cell the default's whole-run ratio minus the reference's (points; > 0: the default loses), the
    worst cell, the oracle ratio where oversubscribed, and the bar checks."""
    by = {(r.sensors, r.fps, r.setting, r.controller): r for r in results}
    cells, worst = [], None
    for (n, f, k, c), r in sorted(by.items()):
        if c != default or (n, f, k, reference) not in by:
            continue
        ref = by[(n, f, k, reference)]
        row = {
            "sensors": n,
            "fps": f,
            "setting": k,
            default: r.whole,
            reference: ref.whole,
            "diff_points": 100 * (r.whole - ref.whole),
            "steady": r.steady,
            "converged_median_s": r.converged_median * TOTAL_FRAMES / 30.0,
        }
        orc = by.get((n, f, k, "oracle"))
        if orc is not None:
            row["oracle"] = orc.whole
            row["vs_oracle"] = r.whole / max(orc.whole, 1e-9) if orc.whole > 0 else float("inf")
        cells.append(row)
        if worst is None or row["diff_points"] > worst["diff_points"]:
            worst = row
    diffs = np.array([c["diff_points"] for c in cells])
    over = [c for c in cells if "oracle" in c]
    return {
        "default": default,
        "reference": reference,
        "settings": sets,
        "cells": cells,
        "worst": worst,
        "mean_diff_points": float(diffs.mean()) if diffs.size else float("nan"),
        "cells_losing_over_0.3": int((diffs > 0.3).sum()),
        "oversubscribed_worst_vs_oracle": max((c["vs_oracle"] for c in over), default=float("nan")),
        "results": [asdict(r) for r in results],
    }


def heatmap(summ: dict[str, Any]) -> Any:
    """The default's interfered frames minus the reference's (points) in every (room, setting) cell; red
    where the default loses, blue where it wins; cells over the 0.3-point tolerance are outlined."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells = summ["cells"]
    rooms = sorted({(c["sensors"], c["fps"]) for c in cells})
    ks = sorted({c["setting"] for c in cells})
    grid = np.full((len(rooms), len(ks)), np.nan)
    for c in cells:
        grid[rooms.index((c["sensors"], c["fps"])), ks.index(c["setting"])] = c["diff_points"]
    lim = max(1.0, float(np.nanmax(np.abs(grid))))
    fig, ax = plt.subplots(figsize=(1.6 + 0.55 * len(ks), 1.2 + 0.32 * len(rooms)))
    im = ax.imshow(grid, cmap="RdBu_r", vmin=-lim, vmax=lim, aspect="auto")
    for (i, j), v in np.ndenumerate(grid):
        if np.isfinite(v):
            ax.text(j, i, f"{v:+.1f}", ha="center", va="center", fontsize=6)
            if v > 0.3:
                ax.add_patch(plt.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="k", lw=1.5))
    ax.set_xticks(range(len(ks)), [str(k) for k in ks])
    ax.set_yticks(range(len(rooms)), [f"N={n}, {f} fps" for n, f in rooms])
    ax.set_xlabel("setting (docs/results/desync/grid/README.md lists each)")
    fig.colorbar(im, ax=ax, label=f"{summ['default']} - {summ['reference']} (points of interfered frames)")
    ax.set_title(
        f"{summ['default']} vs {summ['reference']} (paper Alg. 1): "
        f"worst {summ['worst']['diff_points']:+.2f} points, mean {summ['mean_diff_points']:+.2f}"
    )
    fig.tight_layout()
    return fig


def markdown(summ: dict[str, Any], command: str) -> str:
    """The grid's report: settings, bars, the worst cells and the oversubscribed ones against the oracle."""
    d, ref = summ["default"], summ["reference"]
    lines = [
        f"# {d} against the paper's Algorithm 1 across deployment assumptions",
        "",
        f"Command: `{command}`. Heat map: [grid.png](grid.png); every number: `grid.json`.",
        "",
        "## Bars",
        "",
        f"- cells where {d} loses to {ref} by more than 0.3 points: **{summ['cells_losing_over_0.3']}** of "
        f"{len(summ['cells'])} (worst {summ['worst']['diff_points']:+.2f} at N={summ['worst']['sensors']}, "
        f"{summ['worst']['fps']} fps, setting {summ['worst']['setting']})",
        f"- mean difference: {summ['mean_diff_points']:+.2f} points",
        "- oversubscribed cells, worst ratio to the oracle: "
        f"{summ['oversubscribed_worst_vs_oracle']:.2f} (bar 1.5)",
        "",
        "## Settings",
        "",
        "| setting | " + " | ".join(AXES) + " |",
        "|---|" + "---|" * len(AXES),
    ]
    for k, s in enumerate(summ["settings"]):
        lines.append(f"| {k} | " + " | ".join(f"{s[a]:g}" for a in AXES) + " |")
    lines += [
        "",
        "## The ten cells where it does worst",
        "",
        f"| N | fps | setting | {d} | {ref} | points |",
        "|---|---|---|---|---|---|",
    ]
    for c in sorted(summ["cells"], key=lambda c: -c["diff_points"])[:10]:
        lines.append(
            f"| {c['sensors']} | {c['fps']} | {c['setting']} | {c[d]:.1%} | {c[ref]:.1%} "
            f"| {c['diff_points']:+.2f} |"
        )
    return "\n".join(lines) + "\n"
