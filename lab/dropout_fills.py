"""Where the clean pixels the repair changes come from (issue 42's mask F1 and "clean pixels changed"):
``d2sr.Pipeline`` as shipped (flagged frames repaired, the scene's repair on) on both L515 views of each set
(each view a cold sequence of 60 frames, every other one corrupted), and the same outputs with a filled
dropout put back to no return, after the fact, where a usable scene says (1) the pixel returns in under 90%
of its clean frames, or (2) that and it is not among the frame's deviations from the scene. The share of the
changed clean pixels that are filled dropouts; RMSE change and mask F1 over the corrupted frames; clean
pixels changed over all frames. Development figures only.

With ``--excess``, more rules: put back where the scene returns in under 70%, 50% or 30% of its clean
frames; or under 90% unless the dropouts in the pixel's WxW window exceed those the scene's return rates
expect there (E, the sum of 1 - rate over the pixels the scene has seen return) by more than K x sqrt(E) + C.

Run from the repository root: python -m lab.dropout_fills [--excess] [SET ...]"""

import sys
from pathlib import Path

import cv2
import d2sr.reference as reference
import numpy as np

import d2sr
from lab.held_out import every_other, outside_set

clean = outside_set(Path("../shared/data"))
seen = {}
shipped_evidence = reference.SceneReference.evidence


def evidence(self, *a, **k):  # keep each frame's evidence and its reference's statistics
    ev = shipped_evidence(self, *a, **k)
    seen["ev"], seen["stats"] = ev, self._stats
    return ev


def excess(b, rate, w, k, c):
    """Pixels whose WxW window drops out more than the scene's return rates expect (K sqrt(E) + C more)."""
    known = rate > 0
    o = cv2.boxFilter(((b == 0) & known).astype(np.float32), -1, (w, w), normalize=False)
    e = cv2.boxFilter(np.where(known, 1 - rate, 0).astype(np.float32), -1, (w, w), normalize=False)
    return o - e > k * np.sqrt(e) + c


def under(t, keep_deviating=False, window=None):
    """Rule: a filled dropout back where the scene returns under ``t`` (not where the frame deviates from
    the scene, with ``keep_deviating``; not where dropouts are in excess, with ``window`` = (W, K, C))."""

    def back(b, out, ev, s):
        mask = (b == 0) & (out != b) & (s.rate < t)
        if keep_deviating:
            mask &= ~ev.mask
        if window is not None:
            mask &= ~excess(b, s.rate, *window)
        return mask

    return back


reference.SceneReference.evidence = evidence
args = [a for a in sys.argv[1:] if a != "--excess"]
RULES = {"as shipped": None, "rate < 0.9": under(0.9), "rate < 0.9, not deviating": under(0.9, True)}
if "--excess" in sys.argv:
    RULES |= {f"rate < {t}": under(t) for t in (0.7, 0.5, 0.3)} | {
        f"excess W{w} K{k} C{c}": under(0.9, window=(w, k, c))
        for w in (9, 15)
        for k in (2, 3)
        for c in (2, 6)
    }
for which in args or ["a", "b"]:
    bad = every_other(clean, 4000.0, which)
    sums = {rule: np.zeros(8) for rule in RULES}
    for v in (0, 60):
        pipe = d2sr.Pipeline(4000.0)
        for b, c in zip(bad[v : v + 60], clean[v : v + 60], strict=True):
            seen.clear()
            r = pipe.process(b)
            hit = b != c
            ev, s = seen.get("ev"), seen.get("stats")
            usable = ev is not None and ev.usable and s is not None
            for rule, back_of in RULES.items():
                out, mask = r.depth.copy(), r.mask.copy()
                if back_of is not None and usable:
                    back = back_of(b, out, ev, s)
                    out[back], mask = 0, mask & ~back
                changed = (out != b) & ~hit
                a = sums[rule]
                a[5], a[6], a[7] = (
                    a[5] + changed.sum(),
                    a[6] + (changed & (b == 0)).sum(),
                    a[7] + (~hit).sum(),
                )
                if hit.any():
                    ok = c > 0
                    a[0] += (((b.astype(float) - c) / 4000)[ok] ** 2).sum()
                    a[1] += (((out.astype(float) - c) / 4000)[ok] ** 2).sum()
                    a[2], a[3], a[4] = (
                        a[2] + (mask & hit).sum(),
                        a[3] + (mask & ~hit).sum(),
                        a[4] + (~mask & hit).sum(),
                    )
    for rule, a in sums.items():
        p, rc = a[2] / (a[2] + a[3]), a[2] / (a[2] + a[4])
        print(f"set {which} {rule:26s} RMSE {np.sqrt(a[1] / a[0]) - 1:+.1%}  mask F1 {2 * p * rc / (p + rc):.3f}  "
              f"clean changed {a[5] / a[7]:.2%} (filled dropouts {a[6] / max(a[5], 1):.0%} of it)", flush=True)  # fmt: skip
