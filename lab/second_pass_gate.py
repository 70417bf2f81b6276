"""Would a second pass only on frames the first pass found much in save the worst case its time (issue 44)?
``d2sr.Pipeline(repair="all", scene=False)`` with one pass and with two on both L515 views of each open set
(each view a cold sequence of 60 frames, every other one corrupted), per corrupted frame: its squared error
before and after, and the share of the frame the one-pass repair changed. Then the gate "second pass only
where one pass changed at least TAU of the frame": its RMSE change per set and the share of frames that
would run the second pass. Development figures only. Run from the repository root:
python -m lab.second_pass_gate [SET ...]"""

import sys
from pathlib import Path

import numpy as np

import d2sr
from lab.held_out import SEALED, SETS, every_other, outside_set

clean = outside_set(Path("../shared/data"))
for which in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(clean, 4000.0, which)
    runs = {}
    for passes in (1, 2):
        rows = []
        for v in (0, 60):
            pipe = d2sr.Pipeline(4000.0, repair="all", scene=False, passes=passes)
            for b, c in zip(bad[v : v + 60], clean[v : v + 60], strict=True):
                r = pipe.process(b)
                if not (b != c).any():
                    continue
                ok = c > 0
                before = float((((b.astype(float) - c) / 4000)[ok] ** 2).sum())
                after = float((((r.depth.astype(float) - c) / 4000)[ok] ** 2).sum())
                rows.append((before, after, float(r.mask.mean())))
        runs[passes] = np.array(rows)
    e_in, one, two, share = runs[1][:, 0], runs[1][:, 1], runs[2][:, 1], runs[1][:, 2]
    cells = [f"set {which}: one pass {np.sqrt(one.sum() / e_in.sum()) - 1:+.2%}",
             f"two {np.sqrt(two.sum() / e_in.sum()) - 1:+.2%}"]  # fmt: skip
    for tau in (0.005, 0.01, 0.02, 0.05):
        mixed = np.where(share >= tau, two, one)
        cells.append(
            f"TAU {tau}: {np.sqrt(mixed.sum() / e_in.sum()) - 1:+.2%} ({(share >= tau).mean():.0%} twice)"
        )
    print(" | ".join(cells), flush=True)
