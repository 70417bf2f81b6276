"""How the scene's flags change when a subtle shift (a shifted pixel within SHIFT_CAP of the scene) is explained
only by a frame-before deviation within SHIFT_M of its depth (issue 42): SceneReference(subtle_shifts=False, True),
both L515 views of every open set (the 120 frames seeded as one), each primed as d2sr detect judges a
recording; beside them the clean sequences whole. Precision / recall / clean frames flagged. Development
figures only. Run from the repository root: python -m lab.scene_subtle [SET ...]"""

import sys
from pathlib import Path

import numpy as np

from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set
from lab.scene_gate import cell
from lab.scene_gate import flags as loop_flags

net = open_backend(None, "onnx")
data = Path("../shared/data")
L = outside_set(data)


def flags(frames, scale, on):
    return loop_flags(net, frames, scale, True, {"subtle_shifts": on}, PRIME_FRAMES, still=True)


print(
    "clean off/on",
    {
        n: (int(flags(fr, s, False).sum()), int(flags(fr, s, True).sum()))
        for n, (fr, s) in clean_sequences(data).items()
    },
)
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    cells = []
    for on in (False, True):
        f = np.concatenate([flags(bad[:60], 4000.0, on), flags(bad[60:], 4000.0, on)])
        cells.append(cell(f, hit))
    print(f"| {s.upper()} | {cells[0]} | {cells[1]} |", flush=True)
