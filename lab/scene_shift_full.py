"""Shifted windows that count pixels returning 70% of the time only once the scene's ring holds its 16 clean
frames (issue 42): SceneReference(shift_rate_full=False, as shipped / True), both L515 views of every open set
(the 120 frames seeded as one), each cold (a live sensor) and primed (d2sr detect on a recording); beside them
the clean sequences whole. Precision / recall / clean frames flagged. Development figures only.
Run from the repository root: python -m lab.scene_shift_full [SET ...]"""

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
RUNS = [(p, full) for p in (0, PRIME_FRAMES) for full in (False, True)]


def flags(frames, scale, prime, full):
    return loop_flags(net, frames, scale, True, {"shift_rate_full": full}, prime, still=True)


names = [f"{'primed' if p else 'cold'}, {'full ring' if full else 'shipped'}" for p, full in RUNS]
print("clean sequences flagged:", names)
for n, (fr, s) in clean_sequences(data).items():
    print(n, [int(flags(fr, s, p, full).sum()) for p, full in RUNS])
print("| set | " + " | ".join(names) + " |")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    cells = []
    for p, full in RUNS:
        f = np.concatenate([flags(bad[:60], 4000.0, p, full), flags(bad[60:], 4000.0, p, full)])
        cells.append(cell(f, hit))
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
