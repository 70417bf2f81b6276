"""A detector's flag on a frame the scene finds quiet, kept where the scene cannot vouch for what the detector
saw (issue 42): SensorLoop(unvouched=False, as shipped / True), both L515 views of every open set (each view a
sequence of 60, every other frame corrupted) and, beside them, the clean sequences whole (L515 dev0, dev1,
the hand-held D435), each primed as d2sr detect judges a recording. The detector and unet8 (its mask).
Precision / recall / clean frames flagged. Development figures only.
Run from the repository root: python -m lab.scene_unvouched [SET ...]"""

import sys
from pathlib import Path

import numpy as np

from d2sr.runtime.backends import open_backend
from d2sr.runtime.loop import PRIME_FRAMES
from d2sr.runtime.settings import RunSettings
from lab.held_out import SEALED, SETS, clean_sequences, every_other, outside_set
from lab.scene_gate import cell
from lab.scene_gate import flags as loop_flags

net = open_backend(RunSettings(model="unet8", backend="onnx"))
data = Path("../shared/data")
L = outside_set(data)


def flags(frames, scale, unvouched):
    return loop_flags(net, frames, scale, True, {}, PRIME_FRAMES, True, unvouched)


print("clean sequences flagged (shipped, unvouched):")
for n, (fr, s) in clean_sequences(data).items():
    print(
        f"  {n}: {int(flags(fr, s, False).sum())}, {int(flags(fr, s, True).sum())} of {len(fr)}", flush=True
    )
print("| set | shipped | unvouched |")
print("|---|---|---|")
for s in sys.argv[1:] or sorted(set(SETS) - SEALED):
    bad = every_other(L, 4000.0, s)
    hit = np.array([bool((b != c).any()) for b, c in zip(bad, L)])
    cells = [
        cell(np.concatenate([flags(bad[v : v + 60], 4000.0, u) for v in (0, 60)]), hit) for u in (False, True)
    ]
    print(f"| {s.upper()} | " + " | ".join(cells) + " |", flush=True)
