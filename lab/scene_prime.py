"""How much a recording's look-ahead lifts each development set's recall (issue 42): the loop's flags with
the scene as shipped on both L515 views of every open set (the 120 frames seeded as one, as
``lab/scene_gate.py`` seeds them), each view cold (a live sensor) and primed on its first W frames
(``SensorLoop.primed``, as ``d2sr detect`` and ``d2sr recover`` judge a recording); beside them, the clean
L515 views unseeded. Development figures only. Run from the repository root:
python -m lab.scene_prime [W ...]   (default: 0 32 48; 0 is cold)"""

import sys
from pathlib import Path

import numpy as np

from d2sr.runtime.backends import open_backend
from lab.held_out import SEALED, SETS, every_other, outside_set
from lab.scene_gate import flags as loop_flags
from lab.scene_gate import rates

data = Path("../shared/data")
net = open_backend(None, "onnx")
l515 = outside_set(data)
W = [int(x) for x in sys.argv[1:]] or [0, 32, 48]


def flags(frames, w):
    return loop_flags(net, frames, 4000.0, True, {}, w, still=True)


print("set  " + "  ".join(f"W={w}: P / R / clean flagged".ljust(30) for w in W))
print(
    "clean",
    "  ".join(
        f"{int(np.concatenate([flags(l515[a : a + 60], w) for a in (0, 60)]).sum())} of 120".ljust(30)
        for w in W
    ),
)
for s in sorted(set(SETS) - SEALED):
    bad = every_other(l515, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, l515, strict=True)])
    cells = []
    for w in W:
        f = np.concatenate([flags(bad[a : a + 60], w) for a in (0, 60)])
        cells.append("{precision:.3f} / {recall:.3f} / {clean_flagged} of {clean}".format(**rates(f, hit)))
    print(s, "   ", "  ".join(c.ljust(30) for c in cells), flush=True)
