"""What the synthesis benchmarks share (lab/fill_d435.py, lab/fill_sim.py): pooled RMSE and coverage of
synthesized frames against the true ones, and the RMSE-by-frames-since-real plot (the paper's Fig. 11)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


class Pool:
    """Pooled squared error over pixels with depth in both frames (``units`` per metre; values at or beyond
    ``far`` units count as no depth), and the share of the true frame's pixels the prediction covers."""

    def __init__(self, units: float = 1.0, far: float = np.inf) -> None:
        self.units, self.far = units, far
        self.se = self.both = self.true = 0.0

    def add(self, pred: np.ndarray, true: np.ndarray) -> None:
        ok = (true > 0) & (true < self.far)
        both = ok & (pred > 0) & (pred < self.far)
        self.se += float((((pred.astype(np.float64) - true) / self.units)[both] ** 2).sum())
        self.both += float(both.sum())
        self.true += float(ok.sum())

    def rmse_cm(self) -> float:
        return round(100 * float(np.sqrt(self.se / max(self.both, 1))), 2)

    def coverage(self) -> float:
        return round(self.both / max(self.true, 1), 4)


def plot_curves(
    curves: list[tuple[str, str, dict[str, float]]], title: str, command: str, path: Path
) -> None:
    """RMSE (cm) by frames since the last real frame: one (label, line style, {gap: rmse}) per curve."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from d2sr.eval.plots import save

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for label, style, curve in curves:
        gaps = sorted(curve, key=int)
        ax.plot([int(g) for g in gaps], [curve[g] for g in gaps], style, marker="o", ms=2, label=label)
    ax.set(xlabel="frames since the last real frame", ylabel="RMSE (cm)", ylim=(0, None), title=title)
    ax.legend(fontsize=7)
    fig.text(0.01, -0.06, command, fontsize=6)
    save(fig, path)
