"""What the synthesis benchmarks share (lab/fill_d435.py, lab/fill_sim.py): pooled RMSE and coverage of
synthesized frames against the true ones (``d2sr.eval.fill.PooledError``), and the RMSE-by-frames-since-real plot."""

from __future__ import annotations

from pathlib import Path

from d2sr.eval.fill import PooledError

__all__ = ["PooledError", "plot_curves"]


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
