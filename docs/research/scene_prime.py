"""How much a recording's look-ahead lifts each development set's recall (issue 42): the loop's flags with
the scene as shipped on both L515 views of every open set (the 120 frames seeded as one, as
``bench/scene_gate.py`` seeds them), each view cold (a live sensor) and primed on its first W frames
(``SensorLoop.primed``, as ``d2sr detect`` and ``d2sr recover`` judge a recording); beside them, the clean
L515 views unseeded. Development figures only. Run from the repository root:
python docs/research/scene_prime.py [W ...]   (default: 0 32 48; 0 is cold)"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "bench")
from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from held_out import SEALED, SETS, every_other, outside_set

data = Path("../shared/data")
net = open_backend(None, "onnx")
l515 = outside_set(data)
W = [int(x) for x in sys.argv[1:]] or [0, 32, 48]


def flags(frames, w):
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True)
    caps = (Capture(Frame(f"{i}", f), 4000.0) for i, f in enumerate(frames))
    return np.array([lp.process(c).flagged for c in lp.primed(caps, w)])


print("set  " + "  ".join(f"W={w}: P / R / clean flagged".ljust(30) for w in W))
print("clean", "  ".join(f"{int(np.concatenate([flags(l515[a:a + 60], w) for a in (0, 60)]).sum())} of 120".ljust(30) for w in W))
for s in sorted(set(SETS) - SEALED):
    bad = every_other(l515, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, l515, strict=True)])
    cells = []
    for w in W:
        f = np.concatenate([flags(bad[a:a + 60], w) for a in (0, 60)])
        tp = int((f & hit).sum())
        cells.append(f"{tp / max(int(f.sum()), 1):.3f} / {tp / hit.sum():.3f} / {int((f & ~hit).sum())} of {int((~hit).sum())}")
    print(s, "   ", "  ".join(c.ljust(30) for c in cells), flush=True)
