"""Variants of the scene's offset fill (``SceneReference(offset_fill=True)``, sealed set AC), an observation
(issue 42): each replaces ``d2sr.reference._offsets`` in ``d2sr.Pipeline`` as shipped, primed as ``d2sr recover``
primes a recording, on both L515 views of each set; RMSE change over the corrupted frames, frames made worse,
pixels moved by more than 2 cm put back within 1 cm, clean pixels changed, each view's RMSE change.
Development figures only: no sealed set judged them.

  shipped        as shipped: the offset over the scene's median where the shifted pixels spread by at most
                 1 cm (SHIFT_M), on returns read off by half of it
  sd2            spread up to 2 cm
  half0.25       returns read off by a quarter of the offset
  sd2+half       both
  noise3.5       spread less the pixels' own noise ((hi - lo) / 3.5, squared) up to 1 cm

Run from the repository root: VARS=shipped,sd2 python -m lab.offset_variants SET [SET ...]"""

import os
import sys
from pathlib import Path

import cv2
import d2sr.reference as R
import numpy as np
from d2sr.reference import OFFSET_CAP, RANGE_RATE, SHIFT_M, SHIFT_PX

import scene_repair as SR
from lab.held_out import every_other, outside_set


def make(same=0.5, most=SHIFT_M, noise=0.0):
    def offsets(ev, s, filled, *_):
        m = ev.metres
        has = (m > 0) & (s.rate >= RANGE_RATE) & (s.nz_median > 0)
        diff = np.subtract(m, s.nz_median, dtype=np.float32)
        diff *= has
        shifted = ev.fresh & ev._shift
        k = (SHIFT_PX, SHIFT_PX)
        n = cv2.boxFilter(shifted.astype(np.float32), -1, k, normalize=False)
        within = cv2.boxFilter(has.astype(np.float32), -1, k, normalize=False)
        part = diff * shifted
        count = np.maximum(n, np.float32(1))
        mean = cv2.boxFilter(part, -1, k, normalize=False) / count
        spread = cv2.boxFilter(part * part, -1, k, normalize=False) / count - mean * mean
        if noise:
            own = ((s.hi - s.lo) / np.float32(noise)) ** 2
            spread = (
                spread - cv2.boxFilter((own * shifted).astype(np.float32), -1, k, normalize=False) / count
            )
        whole = (n >= np.float32(SHIFT_PX * SHIFT_PX / 4)) & (2 * n >= within)
        alike = (diff * mean > 0) & (np.abs(diff) >= np.float32(same) * np.abs(mean))
        agree = (np.abs(mean) <= OFFSET_CAP) & (spread <= np.float32(most * most))
        return has & whole & alike & (~filled | agree), mean

    return offsets


VARIANTS = {
    "shipped": {},
    "sd2": {"most": 0.02},
    "half0.25": {"same": 0.25},
    "sd2+half": {"most": 0.02, "same": 0.25},
    "noise3.5": {"noise": 3.5},
}
clean = outside_set(Path("../shared/data"))
for which in sys.argv[1:]:
    bad = every_other(clean, 4000.0, which)
    for name in os.environ.get("VARS", ",".join(VARIANTS)).split(","):
        R._offsets = make(**VARIANTS[name])
        r = SR.scored(
            bad, clean, SR.repaired([bad[:60], bad[60:]], 4000.0, (True, {}), True, True), 4000.0, 2
        )
        print(f"{which:3s} {name:10s} RMSE {r['rmse_change']:+.2%} worse {r['frames_worse']} put back "
              f"{r['moved_2cm_put_back']:.1%} clean changed {r['clean_changed']:.3%} views "
              f"{r['rmse_change_per_view']}", flush=True)  # fmt: skip
