"""The scene's per-pixel median as the temporal recovery model's second input (issue 42, "the repair uses the
reference too"): does unet8-temporal find more of a frame's interference when the frame it compares with is
the still sensor's scene (``SceneReference``'s median of its clean frames) instead of the last frame the
detector passed? ``d2sr.Pipeline(repair="all")`` on both L515 views of outside sets A and B (each view a cold
sequence of 60 frames, every other one corrupted, as ``lab/held_out.py`` corrupts them), three ways:
recover's default (``--model auto``, no scene), unet8-temporal given the last clean frame, and
unet8-temporal given the scene's median wherever the scene has one. RMSE change and mask F1 over the
corrupted frames, clean pixels changed. Development figures only (A and B are development sets).
Run from the repository root: python -m lab.scene_median_input [SET ...]"""

import sys
from pathlib import Path

import numpy as np

import d2sr
from lab.held_out import every_other, outside_set

clean = outside_set(Path("../shared/data"))


def run(which: str, model: str, given: str) -> str:
    bad = every_other(clean, 4000.0, which)
    e_in = e_out = 0.0
    tp = fp = fn = changed = clean_px = 0
    for v in (0, 60):
        pipe = d2sr.Pipeline(4000.0, repair="all", scene=given == "median", scene_repair=False, model=model)
        loop, recover = pipe.loop, pipe.loop.backend.recover

        def with_median(metres, previous, loop=loop, recover=recover):
            ref = loop._reference
            if ref is not None and ref.ready and ref._stats is not None:
                med = ref._stats.nz_median
                previous = np.zeros_like(metres)
                previous[0, : med.shape[0], : med.shape[1]] = med
            return recover(metres, previous)

        if given == "median":  # the backend is shared by every Pipeline of this process: put it back below
            loop.backend.recover = with_median
        try:
            results = [pipe.process(b) for b in bad[v : v + 60]]
        finally:
            vars(loop.backend).pop("recover", None)
        for b, c, r in zip(bad[v : v + 60], clean[v : v + 60], results, strict=True):
            hit = b != c
            if not hit.any():
                continue
            ok = c > 0
            e_in += float((((b.astype(float) - c) / 4000)[ok] ** 2).sum())
            e_out += float((((r.depth.astype(float) - c) / 4000)[ok] ** 2).sum())
            tp, fp, fn = tp + (r.mask & hit).sum(), fp + (r.mask & ~hit).sum(), fn + (~r.mask & hit).sum()
            changed, clean_px = changed + ((r.depth != b) & ~hit).sum(), clean_px + (~hit).sum()
    p, rc = tp / max(tp + fp, 1), tp / max(tp + fn, 1)
    return (f"RMSE {np.sqrt(e_out / e_in) - 1:+.1%}  mask F1 {2 * p * rc / max(p + rc, 1e-9):.3f}  "
            f"clean changed {changed / clean_px:.2%}")  # fmt: skip


for which in sys.argv[1:] or ["a", "b"]:
    for model, given in (("auto", "none"), ("unet8-temporal", "last"), ("unet8-temporal", "median")):
        print(f"set {which}  {model:15s} {given:7s} {run(which, model, given)}", flush=True)
