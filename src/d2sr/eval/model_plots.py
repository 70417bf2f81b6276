"""Plots of the learned stages: precision-recall curves, error CDF (paper Fig. 10), repair gallery."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

__all__ = ["error_cdf", "gallery", "operating_curves", "pr_curves"]


def pr_curves(results: dict[str, dict]) -> Figure:
    """{set name: detector_metrics} -> precision against recall, with the operating point marked."""
    fig, ax = plt.subplots(figsize=(5, 4))
    for name, r in results.items():
        c = r["pr_curve"]
        (line,) = ax.plot(c["recall"], c["precision"], label=name)
        ax.plot([r["recall"]], [r["precision"]], "o", color=line.get_color())
    ax.plot([0.82], [0.98], "k*", label="paper (real L515 test set)")
    ax.set(
        xlabel="recall",
        ylabel="precision",
        xlim=(0, 1.01),
        ylim=(0.4, 1.01),
        title="Detector (dots: threshold 0.5)",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    return fig


def error_cdf(errors: dict[str, np.ndarray], title: str) -> Figure:
    """Cumulative share of truly interfered valid pixels against their absolute error (paper Fig. 10)."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for name, e in errors.items():
        if not e.size:
            continue
        s = np.sort(e * 100)
        ax.plot(s, np.linspace(0, 1, len(s)), label=name)
    ax.set(xscale="symlog", xlabel="absolute error (cm)", ylabel="share of interfered pixels", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return fig


def operating_curves(curves: dict[str, dict], chosen: float, name: str) -> Figure:
    """{set: operating_curve} -> RMSE change against clean pixels changed, one point per mask threshold,
    the model's own threshold circled, the issue's bars dashed."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for set_name, c in curves.items():
        x = 100 * np.asarray(c["clean_changed"])
        y = 100 * np.asarray(c["rmse_vs_identity"])
        (line,) = ax.plot(x, y, ".-", label=set_name)
        k = int(np.argmin(np.abs(np.asarray(c["mask_logit"]) - chosen)))
        ax.plot([x[k]], [y[k]], "o", ms=10, mfc="none", color=line.get_color())
    ax.axhline(-70, color="k", ls="--", lw=0.8)
    ax.axvline(2, color="k", ls="--", lw=0.8)
    ax.set(
        xlabel="clean pixels changed > 1 cm (%)",
        ylabel="RMSE vs identity (%)",
        title=f"{name}: mask threshold trade-off (circle: logit {chosen:g})",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def gallery(rows: list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]) -> Figure:
    """rows of (title, input, true mask, predicted mask, repaired, ground truth) in metres / bool."""
    cols = ("input", "true mask", "predicted mask", "repaired", "ground truth")
    fig, axes = plt.subplots(len(rows), 5, figsize=(15, 2.6 * len(rows)), squeeze=False)
    for r, (title, x, true, pred, out, y) in enumerate(rows):
        vmax = float(np.percentile(y[y > 0], 99)) if (y > 0).any() else 5.0
        for c, img in enumerate((x, true, pred, out, y)):
            ax = axes[r, c]
            if img.dtype == bool:
                ax.imshow(img, cmap="gray", vmin=0, vmax=1)
            else:
                ax.imshow(img, cmap="turbo", vmin=0, vmax=vmax)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(cols[c])
        axes[r, 0].set_ylabel(title, fontsize=8)
    fig.tight_layout()
    return fig


def generalization(real: list[dict], families: list[dict]) -> Figure:
    """Left: false alarms on real clean frames of every sensor. Right: each interference family on real
    L515 frames (recall, recall of a detector trained without it, mask F1)."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.2))
    names = [r["set"] for r in real]
    x = np.arange(len(names))
    a.bar(x - 0.2, [100 * r["flagged"] for r in real], 0.4, label="frames flagged (%)")
    a.bar(
        x + 0.2,
        [100 * r["moved_recover_all"] for r in real],
        0.4,
        label="valid px moved >5 cm, --repair all (%)",
    )
    a.set_xticks(x, names, rotation=35, ha="right", fontsize=8)
    a.set_title("Real clean frames (every mark is a false alarm)")
    a.legend(fontsize=8)
    fams = [r["family"] for r in families]
    x = np.arange(len(fams))
    keys = [("recall", "recall"), ("recall_left_out", "recall, trained without it"), ("mask_f1", "mask F1")]
    keys = [(k, lab) for k, lab in keys if any(k in r for r in families)]
    wid = 0.8 / len(keys)
    for j, (k, lab) in enumerate(keys):
        b.bar(x + (j - (len(keys) - 1) / 2) * wid, [r.get(k, 0) for r in families], wid, label=lab)
    b.set_xticks(x, fams, rotation=35, ha="right", fontsize=8)
    b.set_ylim(0, 1.05)
    b.axhline(0.9, color="grey", lw=0.8, ls=":")
    b.set_title("Each interference family alone on real L515 frames")
    b.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    return fig
