"""Small tight clusters of steady pixels read well off the scene (issue 42: set X's 3x3 blocks), measured and
not made a rule: per frame, the share of the known scene in clusters (5 or more of a 3x3 window) of pixels
that return in 90% of the clean frames, read more than 5 cm off the scene's median and beyond their clean
range's tolerance, and that nothing moving explains. Each open set's L515 views and the clean sequences,
primed as d2sr detect judges a recording (the loop as shipped). The clean frames' largest share, and how
many missed interfered frames reach twice it.
Run from the repository root: python -m lab.scene_clusters [SET ...]"""

import sys
from collections import Counter
from pathlib import Path

import cv2
import d2sr.reference as reference
import numpy as np

from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES, Capture, SensorLoop
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set

net = open_backend(None, "onnx")
data = Path("../shared/data")
L = outside_set(data)
seen = {}
shipped_evidence = reference.SceneReference.evidence


def evidence(self, frame, metres=None):  # each frame's share in clusters, against the scene as it stood
    before = self._before
    ev = shipped_evidence(self, frame, metres)
    seen["share"] = None
    if ev.usable:
        s, m = self._stats, ev.metres
        tol = reference.TOL_ABS + reference.TOL_REL * s.nz_median
        off = (s.rate >= reference.TRUST_RATE) & (s.nz_median > 0) & (m > 0)
        off &= ((m < s.lo - tol) | (m > s.hi + tol)) & (np.abs(m - s.nz_median) > 0.05)
        near = cv2.boxFilter(off.view(np.uint8), -1, (3, 3), normalize=False)
        cluster = off & (near >= 5)
        if cluster.any():
            cluster = reference._unexplained(m, cluster, before)
        seen["share"] = float(np.count_nonzero(cluster)) / ev.known
    return ev


reference.SceneReference.evidence = evidence


def judged(frames, scale):
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True)
    out = []
    for c in lp.primed((Capture(Frame(f"{i}", f), scale) for i, f in enumerate(frames)), PRIME_FRAMES):
        seen.clear()
        flagged = lp.process(c).flagged
        out.append((flagged, seen.get("share")))
    return out


clean_max = max(x for fr, s in clean_sequences(data).values() for _, x in judged(fr, s) if x is not None)
caught, clean_in_sets = Counter(), 0.0
misses = {}
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    rows = judged(bad[:60], 4000.0) + judged(bad[60:], 4000.0)
    for (flagged, x), b, c in zip(rows, bad, L):
        if x is None:
            continue
        if not (b != c).any():
            clean_in_sets = max(clean_in_sets, x)
        elif not flagged:
            misses.setdefault(s, []).append(x)
top = max(clean_max, clean_in_sets)
print(
    f"clean frames' largest share: clean sequences {clean_max:.6f}, the sets' clean frames {clean_in_sets:.6f}"
)
for s, xs in misses.items():
    print(
        f"{s.upper()}: {len(xs)} missed, {sum(x >= 2 * top for x in xs)} reach twice the clean frames' largest"
    )
