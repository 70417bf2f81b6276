"""A do-no-harm candidate for the guard (``d2sr.contract.guard``), tried on 2026-11-27 after set R's
hand-held D435 came out 9.7% worse for its repair (issue 42): 96.6% of the error the repair added to clean
pixels there lay within 2 px of a range edge or a dropout of the clean frame. The candidate: the guard also
leaves alone a returning pixel whose own depth a trusted return (one the mask does not flag) within
``SUPPORT_PX`` pixels shares, within the clamp's noise band (``KEEP_M`` + ``KEEP_REL`` x depth): a
neighbour confirms it. ``--edges``: only where the frame's own 5x5 window holds a dropout or a range step
over 10% of the pixel's depth. ``--backed``: only where no trusted return within ``SUPPORT_PX`` backs the
repair's own depth either (a repair between two surfaces). ``d2sr.Pipeline`` as shipped on both L515 views of each set (each view a cold
sequence of 60 frames) with flagged frames repaired and with every frame repaired, and on the D435 with
flagged frames repaired (every other frame corrupted, as ``lab/held_out.py`` does); the guard as shipped,
then with the candidate. RMSE change and frames made worse over the corrupted frames, mask F1, clean pixels
changed. Development figures only. Run from the repository root:
python -m lab.guard_support [--edges] [--backed] [SET ...]"""

import sys
from pathlib import Path

import numpy as np

import d2sr
import d2sr.contract as contract
from lab.held_out import clean_sequences, every_other, outside_set

SUPPORT_PX = 2
shipped = contract.guard


def supported_guard(edges: bool):
    def guard(metres, pred, mask):
        if metres.ndim == 3:
            pairs = [guard(x, p, m) for x, p, m in zip(metres, pred, mask, strict=True)]
            return np.stack([p for p, _ in pairs]), np.stack([m for _, m in pairs])
        p, keep = shipped(metres, pred, mask)
        x = metres.astype(np.float32, copy=False)
        ys, xs = np.nonzero(keep & (x > 0))
        if not ys.size:
            return p, keep
        r = SUPPORT_PX
        trusted = np.pad(np.where((x > 0) & ~mask, x, np.float32(-1e9)), r, constant_values=-1e9)
        raw = np.pad(x, r)
        v = x[ys, xs]
        tol = np.float32(contract.KEEP_M) + np.float32(contract.KEEP_REL) * v
        sup = np.zeros(v.shape, bool)
        pv = p[ys, xs]
        ptol = np.float32(contract.KEEP_M) + np.float32(contract.KEEP_REL) * pv
        backed = np.zeros(v.shape, bool)  # the repair's depth has a trusted neighbour too
        hole = np.zeros(v.shape, bool)
        lo, hi = np.full(v.shape, np.inf, np.float32), np.zeros(v.shape, np.float32)
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                q = raw[ys + r + dy, xs + r + dx]
                hole |= q <= 0
                lo, hi = np.where(q > 0, np.minimum(lo, q), lo), np.maximum(hi, q)
                if dy or dx:
                    t = trusted[ys + r + dy, xs + r + dx]
                    sup |= np.abs(t - v) <= tol
                    backed |= np.abs(t - pv) <= ptol
        if edges:
            sup &= hole | (hi - lo > 0.1 * v)
        if BACKED:
            sup &= ~backed
        keep[ys[sup], xs[sup]] = False
        return p, keep

    return guard


def score(clean: list, scale: float, which: str, repair: str, views: int) -> str:
    bad = every_other(clean, scale, which)
    n = len(clean) // views
    e_in = e_out = 0.0
    worse = hit_frames = tp = fp = fn = changed = clean_px = 0
    for v in range(0, len(clean), n):
        pipe = d2sr.Pipeline(scale, repair=repair)
        pipe.loop.scene_options = {"reliable_fill": False}  # as shipped when these figures were made
        for b, c in zip(bad[v : v + n], clean[v : v + n], strict=True):
            r = pipe.process(b)
            hit = b != c
            if not hit.any():
                continue
            ok = c > 0
            a = float((((b.astype(float) - c) / scale)[ok] ** 2).sum())
            z = float((((r.depth.astype(float) - c) / scale)[ok] ** 2).sum())
            e_in, e_out, worse, hit_frames = e_in + a, e_out + z, worse + (z > a), hit_frames + 1
            tp, fp, fn = tp + (r.mask & hit).sum(), fp + (r.mask & ~hit).sum(), fn + (~r.mask & hit).sum()
            changed, clean_px = changed + ((r.depth != b) & ~hit).sum(), clean_px + (~hit).sum()
    p, rc = tp / max(tp + fp, 1), tp / max(tp + fn, 1)
    return (f"RMSE {np.sqrt(e_out / e_in) - 1:+.1%}, worse {worse}/{hit_frames}, "
            f"F1 {2 * p * rc / max(p + rc, 1e-9):.3f}, clean changed {changed / clean_px:.2%}")  # fmt: skip


args = sys.argv[1:]
edges = "--edges" in args
BACKED = "--backed" in args
sets = [a for a in args if not a.startswith("--")] or ["r", "a", "b"]
data = Path("../shared/data")
l515, (d435, d435_scale) = outside_set(data), clean_sequences(data)["d435"]
for which in sets:
    for name, guard in (
        ("shipped", shipped),
        ("support" + (", edges" if edges else "") + (", backed" if BACKED else ""), supported_guard(edges)),
    ):
        contract.guard = guard  # refill and repair_frame look it up at each call
        print(
            f"set {which} {name:14s} | L515 flagged: {score(l515, 4000.0, which, 'flagged', 2)} "
            f"| L515 all: {score(l515, 4000.0, which, 'all', 2)} "
            f"| D435 flagged: {score(d435, d435_scale, which, 'flagged', 1)}",
            flush=True,
        )
contract.guard = shipped
