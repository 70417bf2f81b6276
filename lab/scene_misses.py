"""What the interfered frames the loop misses are (issue 42), an observation: both L515 views of each open
set, primed as d2sr detect judges a recording (SensorLoop as shipped, repair "none"). For the interfered
frames caught and those missed: how much of the frame the interference changed (pixels that read > 2 cm
off the clean frame, or drop out or appear), and how much of that lies where the scene, as it stood when
the frame was judged, returns in at least 90% of its clean frames (TRUST_RATE: the pixels it can vouch
for). Medians over the frames.
Run from the repository root: python -m lab.scene_misses [SET ...]"""

import sys
from pathlib import Path

import numpy as np
from d2sr.reference import TRUST_RATE

from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES, Capture, SensorLoop
from lab.held_out import SEALED, SETS, every_other, outside_set

net = open_backend(None, "onnx")
L = outside_set(Path("../shared/data"))


def judged(frames):
    """Each frame's flag, and the scene's return rate as it stood before the frame (None: no scene)."""
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True, prime_still=True)
    caps = [Capture(Frame(f"{i}", f), 4000.0) for i, f in enumerate(frames)]
    out = []
    for c in lp.primed(iter(caps), PRIME_FRAMES):
        ref = lp._reference
        rate = ref._stats.rate.copy() if ref is not None and ref._stats is not None else None
        out.append((lp.process(c).flagged, rate))
    return out


def med(values, fmt="{:.4f}"):
    return fmt.format(float(np.median(values))) if values else "-"


print(
    "| set | caught | missed | changed, caught | changed, missed | missed under 0.1% | vouched, caught | vouched, missed |"
)
print("|---|---|---|---|---|---|---|---|")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    rows = {True: [], False: []}  # caught: (changed share, vouched share)
    for v in (0, 1):
        for i, (flag, rate) in enumerate(judged(bad[60 * v : 60 * v + 60])):
            b, c = bad[60 * v + i].astype(np.float64), L[60 * v + i].astype(np.float64)
            true = np.abs(b - c) > 0.02 * 4000.0
            if not true.any():
                continue
            vouched = float((true & (rate >= TRUST_RATE)).sum() / true.sum()) if rate is not None else np.nan
            rows[bool(flag)].append((float(true.mean()), vouched))
    c, m = rows[True], rows[False]
    tiny = sum(x < 0.001 for x, _ in m)
    vc = [y for _, y in c if not np.isnan(y)]
    vm = [y for _, y in m if not np.isnan(y)]
    print(
        f"| {s.upper()} | {len(c)} | {len(m)} | {med([x for x, _ in c])} | {med([x for x, _ in m])} | {tiny} | "
        f"{med(vc, '{:.2f}')} | {med(vm, '{:.2f}')} |",
        flush=True,
    )
