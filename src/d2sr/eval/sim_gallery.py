"""A gallery of simulated interference: each kind on a simulated frame, with its true mask."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from d2sr.sim.interference import KINDS, InterferenceSettings, Interferer, interfere
from d2sr.sim.rooms import L515, Renderer, SensorNoise
from d2sr.sim.world import direct_view, make_rig

__all__ = ["gallery_figure"]


def _show(ax: plt.Axes, img: np.ndarray, title: str, vmax: float = 7.0, cmap: str = "turbo") -> None:
    shown = np.ma.masked_equal(img, 0) if cmap == "turbo" else img
    cm = plt.get_cmap(cmap).copy()
    cm.set_bad("black")  # no return
    ax.imshow(shown, cmap=cm, vmin=0, vmax=vmax, interpolation="nearest")
    ax.set_facecolor("black")
    ax.set_title(title, fontsize=8)
    ax.axis("off")


def gallery_figure(seed: int = 0) -> Figure:
    """Rows: band, wave, bar, cluster (one interferer), two interferers, direct; columns: clean frame,
    interfered frame (t), the same pattern 3 frames later, true mask."""
    rig = make_rig(seed, 2, people=1)
    cam = Renderer(rig.room, rig.intr, rig.poses[0])
    src = Renderer(rig.room, rig.intr, rig.poses[1])
    noise = SensorNoise(L515, (rig.intr.height, rig.intr.width), seed)
    cfg = InterferenceSettings()
    shape = (rig.intr.height, rig.intr.width)
    scene = cam.render(0.0)
    rows: list[tuple[str, list[Interferer]]] = [
        (k, [Interferer(shape, k, seed + i, 0.14, 18.0)]) for i, k in enumerate(KINDS)
    ]
    rows.append(
        (
            "two interferers",
            [
                Interferer(shape, "band", seed + 7, 0.12, 18.0),
                Interferer(shape, "wave", seed + 8, 0.12, 12.0),
            ],
        )
    )
    d = direct_view(cam, scene.depth, src)
    rows.append(
        ("direct", [Interferer(shape, "direct", seed + 9, 0.05, 0.0, d or (shape[1] / 2, shape[0] / 2))])
    )
    fig, axes = plt.subplots(len(rows), 4, figsize=(11, 2.1 * len(rows)))
    for r, (name, its) in enumerate(rows):
        clean0 = noise.observe(cam.render(0.0))
        bad0, mask0 = interfere(clean0, L515.depth_scale, its, 0, seed, None, cfg)
        clean3 = noise.observe(cam.render(0.1))
        bad3, _ = interfere(clean3, L515.depth_scale, its, 3, seed, None, cfg)
        s = np.float32(L515.depth_scale)
        _show(axes[r, 0], clean0 / s, f"{name}: clean")
        _show(axes[r, 1], bad0 / s, "interfered (frame t)")
        _show(axes[r, 2], bad3 / s, "frame t+3 (pattern drifts)")
        _show(axes[r, 3], mask0.astype(float), f"true mask ({mask0.mean():.1%})", 1.0, "gray")
    fig.tight_layout()
    return fig
