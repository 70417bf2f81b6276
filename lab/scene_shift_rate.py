"""Shifted windows worked out over pixels that return less steadily (issue 42): the loop's flags with
SceneReference(shift_rate=R) for R in 0.9 (as shipped, TRUST_RATE), 0.7 and 0.5, on both L515 views of every
open set (the 120 frames seeded as one), each primed as d2sr detect judges a recording; and on the clean
sequences whole, with the most fresh shifted area any of their frames reached (SHIFT_AREA is 0.01).
Precision / recall / clean frames flagged. Development figures only.
Run from the repository root: python -m lab.scene_shift_rate [SET ...]"""

import sys
from pathlib import Path

import d2sr.reference as R
import numpy as np

from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set

RATES = (0.9, 0.7, 0.5)
net = open_backend(None, "onnx")
data = Path("../shared/data")
L = outside_set(data)
seen = {}
evidence = R.SceneReference.evidence


def kept(self, *a, **k):
    e = evidence(self, *a, **k)
    seen["ev"] = e
    return e


R.SceneReference.evidence = kept


def flags(frames, scale, rate):
    lp = SensorLoop(
        net, make_controller("static", 30, 30), repair="none", scene=True, scene_options={"shift_rate": rate}
    )
    out, area = [], []
    for c in lp.primed(Capture(Frame(f"{i}", f), scale) for i, f in enumerate(frames)):
        seen.clear()
        out.append(lp.process(c).flagged)
        e = seen.get("ev")
        area.append(e.fresh_shifted if e is not None and e.usable else 0.0)
    return np.array(out), np.array(area)


print("clean sequences: frames flagged, most fresh shifted area, per rate", RATES)
for n, (fr, s) in clean_sequences(data).items():
    print(n, [(int(f.sum()), round(float(a.max()), 4)) for f, a in (flags(fr, s, r) for r in RATES)])
print("| set | " + " | ".join(f"shift_rate {r}" for r in RATES) + " |")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    cells = []
    for r in RATES:
        f = np.concatenate([flags(bad[:60], 4000.0, r)[0], flags(bad[60:], 4000.0, r)[0]])
        tp = int((f & hit).sum())
        cells.append(f"{tp / max(f.sum(), 1):.3f} / {tp / hit.sum():.3f} / {int((f & ~hit).sum())}")
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
