"""A candidate tried for issue 42, not kept (decisions.md, 2026-11-27): a dropout where the still sensor's
scene returns in under RATE of its clean frames (env RATE, default 0.9) is filled only where every pass's mask
logit exceeds CUT (env CUTS, default "0 1 2"), not the model's own threshold: the sensor's own dropouts, which
the repair otherwise fills with returns the clean frame does not have. d2sr.Pipeline as shipped, each L515 view
primed on its first 32 frames, flagged frames repaired; per set, RMSE change over the corrupted frames, mask F1,
clean pixels changed, frames made worse. Development sets only.
Run from the repository root: python -m lab.dropout_doubt a b [SET ...]"""

import sys
from pathlib import Path

import numpy as np

import d2sr
import d2sr.contract as C
import d2sr.runtime.backends as B
from d2sr.runtime.loop import SensorLoop
from lab.held_out import every_other, outside_set

RATE = float(__import__("os").environ.get("RATE", "0.9"))
L = outside_set(Path("../shared/data"))
STATE = {"doubt": None, "cut": None}
orig_passes = C.recover_passes


def passes(raw, metres, previous, mask_logit, n):
    d, cut = STATE["doubt"], STATE["cut"]
    if d is None or cut is None:
        return orig_passes(raw, metres, previous, mask_logit, n)
    H, W = d.shape
    thr = np.full(metres.shape, mask_logit, np.float32)
    thr[0, :H, :W] = np.where(d, max(cut, mask_logit), mask_logit)
    logit, pred = raw(metres, previous)
    mask = logit > thr
    for _ in range(n - 1):
        filled, keep = C.refill(metres, pred, mask)
        if not keep.any():
            break
        logit, pred = raw(filled, previous)
        grown = keep | (logit > thr)
        found = (grown & ~mask).any()
        mask = grown
        if not found:
            break
    return pred, mask


B.recover_passes = passes
orig_finish = SensorLoop.finish


def finish(self, d):
    STATE["doubt"] = None
    ref = self._reference
    if d.scene_used and ref is not None and ref._stats is not None:
        raw = d.capture.frame.depth
        STATE["doubt"] = (raw == 0) & (ref._stats.rate < RATE)
    return orig_finish(self, d)


SensorLoop.finish = finish


def run(which, cut):
    STATE["cut"] = cut
    bad = every_other(L, 4000.0, which)
    e_in = e_out = 0.0
    tp = fp = fn = 0
    changed = pix = worse = 0
    for v in (0, 60):
        p = d2sr.Pipeline(4000.0)
        p.prime(bad[v : v + 32])
        for b, c in zip(bad[v : v + 60], L[v : v + 60]):
            r = p.process(b)
            true = b != c
            ok = c > 0
            a = float((((b.astype(float) - c) / 4000)[ok] ** 2).sum())
            z = float((((r.depth.astype(float) - c) / 4000)[ok] ** 2).sum())
            if true.any():
                e_in += a
                e_out += z
                worse += z > a
                tp += int((r.mask & true).sum())
                fp += int((r.mask & ~true).sum())
                fn += int((~r.mask & true).sum())
            changed += int(((r.depth != b) & ~true).sum())
            pix += int((~true).sum())
    f1 = 2 * tp / max(2 * tp + fp + fn, 1)
    return f"rmse {100 * (np.sqrt(e_out / e_in) - 1):+.1f}% F1 {f1:.3f} clean {100 * changed / pix:.3f}% worse {worse}"


for which in sys.argv[1:]:
    print(
        which,
        " | ".join(
            f"cut {c}: {run(which, c)}"
            for c in [None] + [float(x) for x in __import__("os").environ.get("CUTS", "0 1 2").split()]
        ),
        flush=True,
    )
