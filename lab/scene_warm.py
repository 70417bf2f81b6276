"""How much of each set's recall the scene's start-up costs (issue 42): the loop's flags with the scene as
shipped on both L515 views of every set (the 120 frames seeded as one, as ``lab/scene_reference.py`` seeds
them), each view cold (as every result reports it) and warm: preceded by 16 clean frames of the same view
that the set does not use (dev0 frames 120-135, dev1 frames 60-75), as a sensor that has run for half a
second before the interference starts. Precision, recall and clean frames flagged count the set's frames
only. Development figures only. Run from the repository root: python -m lab.scene_warm"""

from pathlib import Path

import cv2
import numpy as np

from d2sr.desync import make_controller
from d2sr.frames import Frame
from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import Capture, SensorLoop
from lab.held_out import SEALED, SETS, every_other, outside_set

data = Path("../shared/data")
net = open_backend(None, "onnx")
l515 = outside_set(data)
before = []
for cap, skip in (("dev0", 120), ("dev1", 60)):
    files = sorted((data / "l515" / cap).glob("*.png"))[skip : skip + 16]
    before.append([cv2.imread(str(f), cv2.IMREAD_UNCHANGED) for f in files])


def flags(frames, warm):
    lp = SensorLoop(net, make_controller("static", 30, 30), repair="none", scene=True)
    for i, f in enumerate(warm):
        lp.process(Capture(Frame(f"w{i}", f), 4000.0))
    return np.array([lp.process(Capture(Frame(f"{i}", f), 4000.0)).flagged for i, f in enumerate(frames)])


print("set   cold P / R / clean flagged      warm P / R / clean flagged")
for w in sorted(set(SETS) - SEALED):
    bad = every_other(l515, 4000.0, w)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, l515, strict=True)])
    cells = []
    for warm in (False, True):
        f = np.concatenate([flags(bad[a : a + 60], before[v] if warm else []) for v, a in enumerate((0, 60))])
        tp = int((f & hit).sum())
        cells.append(
            f"{tp / max(int(f.sum()), 1):.3f} / {tp / hit.sum():.3f} / {int((f & ~hit).sum())} of {int((~hit).sum())}"
        )
    print(w, "   ", cells[0].ljust(30), cells[1])
