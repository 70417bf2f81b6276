"""How well ground-truth labelling recovers known interference masks (``d2sr label-eval``).

* simulated static sequences: a clean sequence for the statistics, then a disjoint interfered stretch
  whose true masks the simulator knows;
* real L515 captures: the first part of each clean sequence gives the statistics, the simulator's
  interference is added to the later, disjoint frames (whose true masks are then known).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from d2sr.frames import open_frames
from d2sr.scene import METHODS, THRESHOLDS, Labeller, clean_stats, f1
from d2sr.sim.calibrate import static_camera
from d2sr.sim.interference import InterferenceSettings, Interferer, interfere
from d2sr.sim.rooms import L515, SensorNoise

__all__ = ["drifting_interference", "evaluate", "real_case", "sim_case"]

Case = tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], float]  # clean, interfered, masks, scale


def drifting_interference(
    frames: list[np.ndarray], scale: float, seed: int, count: Callable[[int], int] = lambda t: 1 + t % 2
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The simulator's interference on a real sequence: two persistent interferers that drift over it;
    frame ``t`` takes the first ``count(t)`` of them (0: left clean). Returns (frames, true masks)."""
    shape = frames[0].shape
    its = [Interferer.draw(shape, seed * 100 + k, InterferenceSettings()) for k in range(2)]
    out, masks = [], []
    for t, f in enumerate(frames):
        n = count(t)
        g, m = interfere(f, scale, its[:n], t, seed) if n else (f, np.zeros(f.shape, bool))
        out.append(g)
        masks.append(m)
    return out, masks


def sim_case(seed: int, clean: int = 100, interfered: int = 30) -> Case:
    cam = static_camera(1000 + seed)
    r = cam.render(0.0)
    noise = SensorNoise(L515, r.depth.shape, seed)
    frames = [noise.observe(r) for _ in range(clean + interfered)]
    bad, masks = drifting_interference(frames[clean:], L515.depth_scale, seed)
    return frames[:clean], bad, masks, L515.depth_scale


def real_case(folder: Path, skip: int = 0, clean: int = 100, seed: int = 0) -> Case:
    reader = open_frames(folder)
    frames = [f.depth for f in reader][skip:]
    scale = reader.depth_scale or 1000.0
    bad, masks = drifting_interference(frames[clean:], scale, seed)
    return frames[:clean], bad, masks, scale


def evaluate(case: Case) -> dict[str, dict[str, float]]:
    """{method/threshold: {precision, recall, f1}} pooled over the interfered frames."""
    clean, bad, masks, scale = case
    stats = clean_stats(lambda: iter(clean), scale)
    out = {}
    true = np.stack(masks)
    for method in METHODS:
        for thr in THRESHOLDS if method == "paper" else ("mu+sigma",):
            lab = Labeller(stats, method, thr)
            pred = np.stack([lab.mask(f.astype(np.float32) / np.float32(scale)) for f in bad])
            p, r, f = f1(pred, true)
            key = method if method == "stats" else f"paper/{thr}"
            out[key] = {"precision": round(p, 4), "recall": round(r, 4), "f1": round(f, 4)}
    return out


def run_all(real_root: Path | None, sims: int = 4, progress: Callable[[str], None] | None = None) -> dict:
    results: dict[str, dict] = {}
    for s in range(sims):
        if progress:
            progress(f"simulated room {s}")
        results[f"sim/{s}"] = evaluate(sim_case(s))
    if real_root is not None:
        for name, skip in (("dev0", 45), ("dev1", 0)):  # dev0: a person walks through the first 45 frames
            if (real_root / name).is_dir():
                if progress:
                    progress(f"L515 {name}")
                results[f"l515/{name}"] = evaluate(real_case(real_root / name, skip=skip, seed=7))
    return results
