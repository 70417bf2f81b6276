"""Follow-up to lab/dropout_fills.py: does the model's own first-pass mask logit tell the sensor's
own dropouts (none in the clean frame either) from interference's (the clean frame returns), among the
dropouts the repair fills where a usable scene says the pixel returns in under 90% of its clean frames?
``d2sr.Pipeline`` as shipped on both L515 views of each set; the single-frame model's logits. Development
figures only. Run from the repository root: python -m lab.dropout_logits [SET ...]"""

import sys
from pathlib import Path

import d2sr.reference as R
import numpy as np

import d2sr
from d2sr.contract.catalog import padded
from d2sr.frames.base import to_metres
from lab.held_out import every_other, outside_set

L = outside_set(Path("../shared/data"))
cap = {}
orig = R.SceneReference.evidence


def ev(self, *a, **k):
    e = orig(self, *a, **k)
    cap["ev"] = e
    cap["stats"] = self._stats
    return e


R.SceneReference.evidence = ev
for which in sys.argv[1:] or ["a", "b"]:
    bad = every_other(L, 4000.0, which)
    nat, intf = [], []
    for v in (0, 60):
        p = d2sr.Pipeline(4000.0)
        single = p.loop.backend.single
        for b, c in zip(bad[v : v + 60], L[v : v + 60]):
            cap.clear()
            r = p.process(b)
            e, s = cap.get("ev"), cap.get("stats")
            if e is None or not e.usable or s is None or not (b != c).any():
                continue
            filled = (b == 0) & (r.depth != b) & (s.rate < 0.9)
            if not filled.any():
                continue
            m = padded(to_metres(b, 4000.0)[None])
            logit, _ = single.raw(m, None)
            lg = logit[0, : b.shape[0], : b.shape[1]]
            nat += list(lg[filled & (c == 0)])
            intf += list(lg[filled & (c > 0)])
    nat, intf = np.array(nat), np.array(intf)
    print(
        which,
        "natural dropouts filled",
        len(nat),
        "logit pct 25/50/75",
        np.percentile(nat, [25, 50, 75]).round(2),
        "| interference dropouts filled",
        len(intf),
        np.percentile(intf, [25, 50, 75]).round(2) if len(intf) else None,
    )
