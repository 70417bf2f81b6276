"""A primed scene kept only if the sensor held still over the frames ahead (issue 42):
SensorLoop(prime_still=False, as shipped / True), every open set's two L515 views and its hand-held D435 part
(a moving sensor), each primed as d2sr detect judges a recording; beside them the clean sequences whole.
Precision / recall / clean frames flagged. Development figures only.
Run from the repository root: python -m lab.scene_prime_still [SET ...]"""

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
seqs = clean_sequences(data)
d435 = seqs["d435"][0]


def flags(frames, scale, still):
    return loop_flags(net, frames, scale, True, {}, PRIME_FRAMES, still)


print(
    "clean sequences flagged (any scene / settled only):",
    {n: tuple(int(flags(fr, s, st).sum()) for st in (False, True)) for n, (fr, s) in seqs.items()},
)
print("| set | L515, any scene | L515, settled only | D435, any scene | D435, settled only |")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    bd = every_other(d435, 1000.0, s)
    hd = np.array([bool((b != c).any()) for b, c in zip(bd, d435)])
    cells = [
        cell(np.concatenate([flags(bad[:60], 4000.0, st), flags(bad[60:], 4000.0, st)]), hit)
        for st in (False, True)
    ]
    cells += [cell(flags(bd, 1000.0, st), hd) for st in (False, True)]
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
